// dds-tcp-probe: what Fast DDS 2.9 does over TCP between two sites, with the link's own types and
// QoS (idl/dds/Federation.idl; docs/federation.md), without a bridge. Test support, not product.
//
// One process per site. The "pong" side serves calls on urs/rpc/<space>/request, answering each on
// urs/rpc/<caller>/reply with a reply of --reply-bytes, and writes one catalog entry
// (transient-local) on urs/catalog. The "ping" side reads the catalog and calls the pong side
// every --interval-ms with a request of --request-bytes, each waiting up to --timeout-ms. Each
// side prints one line per event on stdout, "<ms since start> <event> <details>", for the scripts
// that drive it (tests/e2e/sites):
//   joined                    the participant exists (the transports and settings it took)
//   matched <topic> <n>       a writer or reader of <topic> matched (n: matches now); unmatched too
//   catalog <space>/<name>    the pong side's entry was read
//   participant <what> <name> discovery of another participant: discovered, removed, dropped
//   reply <n> <rtt_us> <bytes>, timeout <n>  a call answered / not answered in time (ping side)
//   served <n>                a call served (pong side, every --report-every)
//   summary ...               at exit: calls, replies, timeouts, RTT percentiles
//
// Transport: --transport tcp|udp. TCP: --listen PORT (a TCP server; none = it only connects out),
// --wan A.B.C.D (the public address: Fast DDS announces it with its locators), --announce A.B.C.D
// (the participant's own unicast locators at that address, physical port --announce-port or the
// listening port, logical port --announce-logical), --peer HOST:PORT (repeated: initial peers, TCP
// servers to connect to), --logical-port N (of the peers' and servers' locators), --keep-alive-ms,
// --keep-alive-timeout-ms.
// --builtin keeps Fast DDS's builtin transports as well. Discovery: --discovery
// simple|server|client|super_client, --server-id N (server: its metatraffic locator is the
// listening port, logical port --logical-port), --server HOST:PORT (client: the server with id 0,
// then 1, ...). Security: --pki FOLDER (deploy/pki.sh's layout, member <space>).
// --duration-s N: exit after N seconds (else on SIGTERM / SIGINT), printing the summary; --replies N
// (ping): exit once N replies arrived. The ping side exits 0 when it got its replies (at least
// one), 3 when not. --verbose: Fast DDS's own warnings and errors.

#include <arpa/inet.h>
#include <fastdds/rtps/attributes/ServerAttributes.h>
#include <fastdds/rtps/transport/TCPv4TransportDescriptor.h>
#include <fastdds/rtps/transport/UDPv4TransportDescriptor.h>
#include <fastrtps/utils/IPLocator.h>
#include <netdb.h>
#include <signal.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <deque>
#include <fastdds/dds/domain/DomainParticipant.hpp>
#include <fastdds/dds/domain/DomainParticipantFactory.hpp>
#include <fastdds/dds/domain/DomainParticipantListener.hpp>
#include <fastdds/dds/log/Log.hpp>
#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/publisher/DataWriterListener.hpp>
#include <fastdds/dds/publisher/Publisher.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/DataReaderListener.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>
#include <fastdds/dds/subscriber/Subscriber.hpp>
#include <fastdds/dds/topic/Topic.hpp>
#include <iostream>
#include <map>
#include <mutex>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "FederationPubSubTypes.h"

namespace {

namespace fdds = eprosima::fastdds::dds;
namespace rtps = eprosima::fastrtps::rtps;
using Clock = std::chrono::steady_clock;

const Clock::time_point kStart = Clock::now();
std::mutex output_mutex;

void event(const std::string& what) {
  const auto ms = std::chrono::duration_cast<std::chrono::milliseconds>(Clock::now() - kStart).count();
  std::lock_guard lock(output_mutex);
  std::cout << ms << ' ' << what << std::endl;
}

struct Options {
  std::string role;  // ping | pong
  std::string space;
  std::string peer_space;
  uint32_t domain = 0;
  std::string transport = "tcp";
  uint16_t listen = 0;
  std::string wan;
  std::string announce;  // TCP: the address announced as this participant's own (its unicast locators)
  uint16_t announce_logical = 0;
  uint16_t announce_port = 0;  // the physical port of the announced locators (0: --listen)
  std::vector<std::string> peers;
  uint16_t logical_port = 0;
  bool builtin = false;
  std::string discovery = "simple";
  int server_id = 0;
  std::vector<std::string> servers;
  std::string pki;
  std::size_t request_bytes = 64;
  std::size_t reply_bytes = 64;
  int interval_ms = 200;
  int timeout_ms = 5000;
  int duration_s = 0;
  long replies_wanted = 0;  // ping: exit once this many replies arrived (0: run for --duration-s)
  int report_every = 50;
  int participant_lease_ms = 20000;
  int keep_alive_ms = 0;  // TCP keep-alive frequency (0: Fast DDS's default)
  int keep_alive_timeout_ms = 0;
  bool verbose = false;  // Fast DDS's own log (warnings and errors) on stderr
};

[[noreturn]] void usage(const std::string& why) {
  std::cerr << "dds-tcp-probe: " << why
            << "\nusage: dds-tcp-probe --role ping|pong --space S --peer-space P [--domain N] [--transport tcp|udp]"
               " [--listen PORT] [--wan A.B.C.D] [--peer HOST:PORT]... [--logical-port N] [--builtin]"
               " [--discovery simple|server|client|super_client] [--server-id N] [--server HOST:PORT]..."
               " [--pki FOLDER] [--request-bytes N] [--reply-bytes N] [--interval-ms N] [--timeout-ms N]"
               " [--duration-s N] [--participant-lease-ms N] [--keep-alive-ms N] [--keep-alive-timeout-ms N]\n";
  std::exit(2);
}

Options parse(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string flag = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) usage(flag + " needs a value");
      return argv[++i];
    };
    auto number = [&]() { return std::stol(value()); };
    if (flag == "--role")
      o.role = value();
    else if (flag == "--space")
      o.space = value();
    else if (flag == "--peer-space")
      o.peer_space = value();
    else if (flag == "--domain")
      o.domain = static_cast<uint32_t>(number());
    else if (flag == "--transport")
      o.transport = value();
    else if (flag == "--listen")
      o.listen = static_cast<uint16_t>(number());
    else if (flag == "--wan")
      o.wan = value();
    else if (flag == "--announce")
      o.announce = value();
    else if (flag == "--announce-logical")
      o.announce_logical = static_cast<uint16_t>(number());
    else if (flag == "--announce-port")
      o.announce_port = static_cast<uint16_t>(number());
    else if (flag == "--peer")
      o.peers.push_back(value());
    else if (flag == "--logical-port")
      o.logical_port = static_cast<uint16_t>(number());
    else if (flag == "--builtin")
      o.builtin = true;
    else if (flag == "--verbose")
      o.verbose = true;
    else if (flag == "--discovery")
      o.discovery = value();
    else if (flag == "--server-id")
      o.server_id = static_cast<int>(number());
    else if (flag == "--server")
      o.servers.push_back(value());
    else if (flag == "--pki")
      o.pki = value();
    else if (flag == "--request-bytes")
      o.request_bytes = static_cast<std::size_t>(number());
    else if (flag == "--reply-bytes")
      o.reply_bytes = static_cast<std::size_t>(number());
    else if (flag == "--interval-ms")
      o.interval_ms = static_cast<int>(number());
    else if (flag == "--timeout-ms")
      o.timeout_ms = static_cast<int>(number());
    else if (flag == "--duration-s")
      o.duration_s = static_cast<int>(number());
    else if (flag == "--replies")
      o.replies_wanted = number();
    else if (flag == "--report-every")
      o.report_every = static_cast<int>(number());
    else if (flag == "--participant-lease-ms")
      o.participant_lease_ms = static_cast<int>(number());
    else if (flag == "--keep-alive-ms")
      o.keep_alive_ms = static_cast<int>(number());
    else if (flag == "--keep-alive-timeout-ms")
      o.keep_alive_timeout_ms = static_cast<int>(number());
    else
      usage("unknown flag " + flag);
  }
  if (o.role != "ping" && o.role != "pong") usage("--role ping|pong");
  if (o.space.empty() || o.peer_space.empty()) usage("--space and --peer-space are required");
  return o;
}

std::string resolve(const std::string& host) {
  addrinfo hints{};
  hints.ai_family = AF_INET;
  addrinfo* found = nullptr;
  if (getaddrinfo(host.c_str(), nullptr, &hints, &found) != 0 || found == nullptr) {
    throw std::runtime_error("cannot resolve " + host);
  }
  char address[64] = {};
  getnameinfo(found->ai_addr, found->ai_addrlen, address, sizeof address, nullptr, 0, NI_NUMERICHOST);
  freeaddrinfo(found);
  return address;
}

// HOST:PORT as a locator of the transport in use (TCP: physical port PORT, logical port as set).
rtps::Locator_t locator_of(const std::string& peer, const Options& o) {
  const auto colon = peer.rfind(':');
  if (colon == std::string::npos) throw std::runtime_error("peer '" + peer + "': HOST:PORT expected");
  const std::string address = resolve(peer.substr(0, colon));
  const auto port = static_cast<uint16_t>(std::stoi(peer.substr(colon + 1)));
  rtps::Locator_t locator;
  if (o.transport == "tcp") {
    locator.kind = LOCATOR_KIND_TCPv4;
    rtps::IPLocator::setIPv4(locator, address);
    rtps::IPLocator::setPhysicalPort(locator, port);
    rtps::IPLocator::setLogicalPort(locator, o.logical_port);
  } else {
    locator.kind = LOCATOR_KIND_UDPv4;
    rtps::IPLocator::setIPv4(locator, address);
    locator.port = port;
  }
  return locator;
}

std::string uri(const std::string& path) { return "file://" + path; }

// The link's keyed-state and DDS-RPC QoS (services' dds_qos.hpp, dds_rpc.hpp), restated.
template <class Qos>
Qos keyed(Qos qos, int32_t instances) {
  qos.reliability().kind = fdds::RELIABLE_RELIABILITY_QOS;
  qos.durability().kind = fdds::TRANSIENT_LOCAL_DURABILITY_QOS;
  qos.history().kind = fdds::KEEP_LAST_HISTORY_QOS;
  qos.history().depth = 1;
  qos.resource_limits().max_instances = instances;
  qos.resource_limits().max_samples_per_instance = 1;
  qos.resource_limits().max_samples = instances;
  qos.resource_limits().allocated_samples = 16;
  return qos;
}

fdds::DataWriterQos writer_qos(bool synchronous) {
  auto qos = keyed(fdds::DATAWRITER_QOS_DEFAULT, 4096);
  qos.publish_mode().kind = synchronous ? fdds::SYNCHRONOUS_PUBLISH_MODE : fdds::ASYNCHRONOUS_PUBLISH_MODE;
  qos.reliable_writer_qos().times.heartbeatPeriod = eprosima::fastrtps::Duration_t(0.1);
  return qos;
}

std::string locators_text(const rtps::LocatorList_t& list) {
  std::string text;
  for (const auto& locator : list) {
    text += (text.empty() ? "" : ",") + rtps::IPLocator::ip_to_string(locator) + ":" +
            std::to_string(rtps::IPLocator::getPhysicalPort(locator)) + "/" +
            std::to_string(rtps::IPLocator::getLogicalPort(locator));
    if (locator.kind == LOCATOR_KIND_TCPv4 && rtps::IPLocator::hasWan(locator)) {
      text += "(wan " + rtps::IPLocator::toWanstring(locator) + ")";
    }
  }
  return text.empty() ? "-" : text;
}

rtps::LocatorList_t unicast_of(const rtps::RemoteLocatorList& locators) {
  rtps::LocatorList_t list;
  for (const auto& locator : locators.unicast) list.push_back(locator);
  return list;
}

class ParticipantEvents : public fdds::DomainParticipantListener {
 public:
  void on_participant_discovery(fdds::DomainParticipant*, rtps::ParticipantDiscoveryInfo&& info) override {
    const char* what = "changed";
    switch (info.status) {
      case rtps::ParticipantDiscoveryInfo::DISCOVERED_PARTICIPANT:
        what = "discovered";
        break;
      case rtps::ParticipantDiscoveryInfo::REMOVED_PARTICIPANT:
        what = "removed";
        break;
      case rtps::ParticipantDiscoveryInfo::DROPPED_PARTICIPANT:
        what = "dropped";
        break;
      default:
        break;
    }
    event(std::string("participant ") + what + " " + info.info.m_participantName.to_string() +
          " metatraffic=" + locators_text(unicast_of(info.info.metatraffic_locators)) +
          " user=" + locators_text(unicast_of(info.info.default_locators)));
  }
};

class MatchEvents : public fdds::DataWriterListener {
 public:
  explicit MatchEvents(std::string topic) : topic_(std::move(topic)) {}
  void on_publication_matched(fdds::DataWriter*, const fdds::PublicationMatchedStatus& status) override {
    {
      std::lock_guard lock(mutex_);
      matched_ = status.current_count;
    }
    changed_.notify_all();
    event(std::string(status.current_count_change > 0 ? "matched " : "unmatched ") + topic_ + " writer " +
          std::to_string(status.current_count));
  }
  bool wait_matched(std::chrono::milliseconds limit) {
    std::unique_lock lock(mutex_);
    return changed_.wait_for(lock, limit, [&] { return matched_ > 0; });
  }

 private:
  std::string topic_;
  std::mutex mutex_;
  std::condition_variable changed_;
  int matched_ = 0;
};

std::atomic<bool> stopping{false};
std::mutex stop_mutex;
std::condition_variable stop_changed;

// The serving side: each request answered at once (on the listener thread: the probe is not the
// link, which answers from a thread of its own; a synchronous write here is what the link avoids,
// but a probe serving one caller at a time does not deadlock on it).
class Server : public fdds::DataReaderListener {
 public:
  Server(fdds::DataWriter* replies, std::size_t reply_bytes, int report_every)
      : replies_(replies), reply_(reply_bytes, 'r'), report_every_(report_every) {}
  void on_data_available(fdds::DataReader* reader) override {
    urs::dds::CallRequest request;
    fdds::SampleInfo info;
    while (reader->take_next_sample(&request, &info) == ReturnCode_t::RETCODE_OK) {
      if (!info.valid_data) continue;
      urs::dds::CallReply reply;
      reply.request_id(request.request_id());
      reply.status(0);
      reply.payload(std::vector<uint8_t>(reply_.begin(), reply_.end()));
      if (!replies_->write(&reply)) event("reply-write-failed " + request.request_id());
      // A reply stays registered for a while (as the link keeps it until its caller is done):
      // unregistered at once, its keep-last-1 instance would hold the unregistration instead.
      retired_.push_back(request.request_id());
      if (retired_.size() > 64) {
        urs::dds::CallReply old;
        old.request_id(retired_.front());
        retired_.pop_front();
        replies_->unregister_instance(&old, fdds::HANDLE_NIL);  // lookup_instance: not in Fast DDS 2.9
      }
      if (++served_ % report_every_ == 0 || served_ == 1) event("served " + std::to_string(served_));
    }
  }
  void on_subscription_matched(fdds::DataReader*, const fdds::SubscriptionMatchedStatus& status) override {
    event(std::string(status.current_count_change > 0 ? "matched " : "unmatched ") + "request reader " +
          std::to_string(status.current_count));
  }

 private:
  fdds::DataWriter* replies_;
  std::string reply_;
  int report_every_;
  long served_ = 0;
  std::deque<std::string> retired_;
};

// The calling side: replies by request id.
class Caller : public fdds::DataReaderListener {
 public:
  void on_data_available(fdds::DataReader* reader) override {
    urs::dds::CallReply reply;
    fdds::SampleInfo info;
    while (reader->take_next_sample(&reply, &info) == ReturnCode_t::RETCODE_OK) {
      if (!info.valid_data) continue;
      std::lock_guard lock(mutex_);
      answered_[reply.request_id()] = reply.payload().size();
      arrived_.notify_all();
    }
  }
  void on_subscription_matched(fdds::DataReader*, const fdds::SubscriptionMatchedStatus& status) override {
    event(std::string(status.current_count_change > 0 ? "matched " : "unmatched ") + "reply reader " +
          std::to_string(status.current_count));
  }
  // The reply's size, or -1 when none came in time.
  long wait(const std::string& id, Clock::time_point until) {
    std::unique_lock lock(mutex_);
    arrived_.wait_until(lock, until, [&] { return answered_.count(id) > 0 || stopping; });
    auto it = answered_.find(id);
    if (it == answered_.end()) return -1;
    const long size = static_cast<long>(it->second);
    answered_.erase(it);
    return size;
  }

 private:
  std::mutex mutex_;
  std::condition_variable arrived_;
  std::map<std::string, std::size_t> answered_;
};

class CatalogEvents : public fdds::DataReaderListener {
 public:
  void on_data_available(fdds::DataReader* reader) override {
    urs::dds::ServiceEntry entry;
    fdds::SampleInfo info;
    while (reader->take_next_sample(&entry, &info) == ReturnCode_t::RETCODE_OK) {
      if (info.valid_data) event("catalog " + entry.space() + "/" + entry.name());
    }
  }
  void on_liveliness_changed(fdds::DataReader*, const fdds::LivelinessChangedStatus& status) override {
    event("catalog-liveliness alive=" + std::to_string(status.alive_count));
  }
};

}  // namespace

int main(int argc, char** argv) {
  const Options o = parse(argc, argv);
  // SIGTERM and SIGINT blocked in every thread (Fast DDS's inherit the mask); one thread waits for them.
  sigset_t shutdown_signals;
  sigemptyset(&shutdown_signals);
  sigaddset(&shutdown_signals, SIGTERM);
  sigaddset(&shutdown_signals, SIGINT);
  pthread_sigmask(SIG_BLOCK, &shutdown_signals, nullptr);
  std::thread([shutdown_signals] {
    int signal_number = 0;
    sigwait(&shutdown_signals, &signal_number);
    {
      std::lock_guard lock(stop_mutex);
      stopping = true;
    }
    stop_changed.notify_all();
  }).detach();

  if (o.verbose) fdds::Log::SetVerbosity(fdds::Log::Warning);
  auto* factory = fdds::DomainParticipantFactory::get_instance();
  fdds::DomainParticipantQos qos = factory->get_default_participant_qos();
  qos.name("probe/" + o.space);
  qos.wire_protocol().builtin.discovery_config.leaseDuration =
      eprosima::fastrtps::Duration_t(o.participant_lease_ms / 1000.0);
  qos.wire_protocol().builtin.discovery_config.leaseDuration_announcementperiod = eprosima::fastrtps::Duration_t(0.75);
  qos.transport().use_builtin_transports = o.builtin;
  std::string settings = "transport=" + o.transport;
  if (o.transport == "tcp") {
    auto tcp = std::make_shared<eprosima::fastdds::rtps::TCPv4TransportDescriptor>();
    if (o.listen != 0) tcp->add_listener_port(o.listen);
    if (!o.wan.empty()) tcp->set_WAN_address(o.wan);
    tcp->enable_tcp_nodelay = true;
    tcp->sendBufferSize = 4 << 20;
    tcp->receiveBufferSize = 4 << 20;
    if (o.keep_alive_ms > 0) tcp->keep_alive_frequency_ms = static_cast<uint32_t>(o.keep_alive_ms);
    if (o.keep_alive_timeout_ms > 0) tcp->keep_alive_timeout_ms = static_cast<uint32_t>(o.keep_alive_timeout_ms);
    qos.transport().user_transports.push_back(tcp);
    settings += " listen=" + std::to_string(o.listen) + " wan=" + (o.wan.empty() ? "-" : o.wan) +
                " keep_alive_ms=" + std::to_string(tcp->keep_alive_frequency_ms) + "/" +
                std::to_string(tcp->keep_alive_timeout_ms) + " max_message=" + std::to_string(tcp->maxMessageSize);
  } else {
    auto udp = std::make_shared<eprosima::fastdds::rtps::UDPv4TransportDescriptor>();
    udp->sendBufferSize = 4 << 20;
    udp->receiveBufferSize = 4 << 20;
    qos.transport().user_transports.push_back(udp);
  }
  if (!o.announce.empty()) {
    // The participant's own unicast locators, metatraffic and user data, at the announced address
    // and the listening port (logical ports: Fast DDS's when 0).
    // Metatraffic on logical port --announce-logical (a discovery server's must be set), user data
    // on Fast DDS's.
    for (auto* list : {&qos.wire_protocol().builtin.metatrafficUnicastLocatorList,
                       &qos.wire_protocol().default_unicast_locator_list}) {
      rtps::Locator_t locator;
      locator.kind = LOCATOR_KIND_TCPv4;
      rtps::IPLocator::setIPv4(locator, o.announce);
      rtps::IPLocator::setPhysicalPort(locator, o.announce_port != 0 ? o.announce_port : o.listen);
      rtps::IPLocator::setLogicalPort(
          locator, list == &qos.wire_protocol().builtin.metatrafficUnicastLocatorList ? o.announce_logical : 0);
      list->push_back(locator);
    }
    settings += " announce=" + o.announce;
  }
  for (const auto& peer : o.peers) qos.wire_protocol().builtin.initialPeersList.push_back(locator_of(peer, o));
  auto& discovery = qos.wire_protocol().builtin.discovery_config;
  if (o.discovery == "server") {
    discovery.discoveryProtocol = rtps::DiscoveryProtocol_t::SERVER;
    rtps::get_server_client_default_guidPrefix(o.server_id, qos.wire_protocol().prefix);
    if (o.transport == "tcp" && o.announce.empty()) {
      // A TCP server's metatraffic locator: its listening port, on every address (0.0.0.0).
      rtps::Locator_t locator;
      locator.kind = LOCATOR_KIND_TCPv4;
      rtps::IPLocator::setIPv4(locator, "0.0.0.0");
      rtps::IPLocator::setPhysicalPort(locator, o.listen);
      rtps::IPLocator::setLogicalPort(locator, o.logical_port);
      qos.wire_protocol().builtin.metatrafficUnicastLocatorList.push_back(locator);
    }
  } else if (o.discovery == "client" || o.discovery == "super_client") {
    discovery.discoveryProtocol =
        o.discovery == "client" ? rtps::DiscoveryProtocol_t::CLIENT : rtps::DiscoveryProtocol_t::SUPER_CLIENT;
  } else if (o.discovery != "simple") {
    usage("--discovery simple|server|client|super_client");
  }
  for (std::size_t id = 0; id < o.servers.size(); ++id) {
    eprosima::fastdds::rtps::RemoteServerAttributes server;
    rtps::get_server_client_default_guidPrefix(static_cast<int>(id), server.guidPrefix);
    server.metatrafficUnicastLocatorList.push_back(locator_of(o.servers[id], o));
    discovery.m_DiscoveryServers.push_back(server);
  }
  settings += " discovery=" + o.discovery;
  if (!o.pki.empty()) {
    const std::string member = o.pki + "/" + o.space + "/";
    const std::vector<std::pair<std::string, std::string>> properties{
        {"dds.sec.auth.plugin", "builtin.PKI-DH"},
        {"dds.sec.auth.builtin.PKI-DH.identity_ca", uri(o.pki + "/ca.pem")},
        {"dds.sec.auth.builtin.PKI-DH.identity_certificate", uri(member + "identity.pem")},
        {"dds.sec.auth.builtin.PKI-DH.private_key", uri(member + "identity.key")},
        {"dds.sec.access.plugin", "builtin.Access-Permissions"},
        {"dds.sec.access.builtin.Access-Permissions.permissions_ca", uri(o.pki + "/ca.pem")},
        {"dds.sec.access.builtin.Access-Permissions.governance", uri(o.pki + "/governance.p7s")},
        {"dds.sec.access.builtin.Access-Permissions.permissions", uri(member + "permissions.p7s")},
        {"dds.sec.crypto.plugin", "builtin.AES-GCM-GMAC"},
    };
    for (const auto& [name, value] : properties) qos.properties().properties().emplace_back(name, value);
    settings += " secured";
  }

  ParticipantEvents participant_events;
  fdds::DomainParticipant* participant =
      factory->create_participant(o.domain, qos, &participant_events, fdds::StatusMask::none());
  if (participant == nullptr) {
    event("join-failed " + settings);
    return 1;
  }
  {
    fdds::DomainParticipantQos taken;
    participant->get_qos(taken);
    event("joined " + settings);
  }

  fdds::TypeSupport entry_type(new urs::dds::ServiceEntryPubSubType());
  fdds::TypeSupport request_type(new urs::dds::CallRequestPubSubType());
  fdds::TypeSupport reply_type(new urs::dds::CallReplyPubSubType());
  entry_type.register_type(participant);
  request_type.register_type(participant);
  reply_type.register_type(participant);
  // On a secured link the shared topics are written in the writer's space's partition and read in
  // every one the permissions grant (deploy/pki.sh's default: all).
  fdds::PublisherQos shared_publisher_qos = fdds::PUBLISHER_QOS_DEFAULT;
  fdds::SubscriberQos shared_subscriber_qos = fdds::SUBSCRIBER_QOS_DEFAULT;
  if (!o.pki.empty()) {
    shared_publisher_qos.partition().push_back(o.space.c_str());
    shared_subscriber_qos.partition().push_back("*");
  }
  fdds::Publisher* publisher = participant->create_publisher(fdds::PUBLISHER_QOS_DEFAULT);
  fdds::Subscriber* subscriber = participant->create_subscriber(fdds::SUBSCRIBER_QOS_DEFAULT);
  fdds::Publisher* shared_publisher = participant->create_publisher(shared_publisher_qos);
  fdds::Subscriber* shared_subscriber = participant->create_subscriber(shared_subscriber_qos);
  fdds::Topic* catalog = participant->create_topic("urs/catalog", entry_type.get_type_name(), fdds::TOPIC_QOS_DEFAULT);

  Caller caller;
  CatalogEvents catalog_events;
  std::vector<std::unique_ptr<MatchEvents>> match_events;
  int result = 0;
  long calls = 0, replies = 0, timeouts = 0;
  std::vector<long> rtts_us;
  if (o.role == "pong") {
    fdds::Topic* requests = participant->create_topic("urs/rpc/" + o.space + "/request", request_type.get_type_name(),
                                                      fdds::TOPIC_QOS_DEFAULT);
    fdds::Topic* replies_topic = participant->create_topic("urs/rpc/" + o.peer_space + "/reply",
                                                           reply_type.get_type_name(), fdds::TOPIC_QOS_DEFAULT);
    match_events.push_back(std::make_unique<MatchEvents>("reply"));
    fdds::DataWriter* reply_writer =
        publisher->create_datawriter(replies_topic, writer_qos(true), match_events.back().get());
    match_events.push_back(std::make_unique<MatchEvents>("catalog"));
    fdds::DataWriter* catalog_writer =
        shared_publisher->create_datawriter(catalog, writer_qos(false), match_events.back().get());
    static Server server(reply_writer, o.reply_bytes, o.report_every);
    fdds::DataReader* request_reader =
        subscriber->create_datareader(requests, keyed(fdds::DATAREADER_QOS_DEFAULT, 4096), &server);
    if (reply_writer == nullptr || catalog_writer == nullptr || request_reader == nullptr) {
      event("endpoint-refused");
      return 1;
    }
    urs::dds::ServiceEntry entry;
    entry.space(o.space);
    entry.name("probe.echo");
    entry.interface_name("URS.Diagnostic");
    if (!catalog_writer->write(&entry)) event("catalog-write-failed");
    std::unique_lock lock(stop_mutex);
    stop_changed.wait_for(lock, o.duration_s > 0 ? std::chrono::seconds(o.duration_s) : std::chrono::hours(24 * 365),
                          [] { return stopping.load(); });
  } else {
    fdds::Topic* requests = participant->create_topic("urs/rpc/" + o.peer_space + "/request",
                                                      request_type.get_type_name(), fdds::TOPIC_QOS_DEFAULT);
    fdds::Topic* replies_topic =
        participant->create_topic("urs/rpc/" + o.space + "/reply", reply_type.get_type_name(), fdds::TOPIC_QOS_DEFAULT);
    match_events.push_back(std::make_unique<MatchEvents>("request"));
    fdds::DataWriter* request_writer =
        publisher->create_datawriter(requests, writer_qos(true), match_events.back().get());
    MatchEvents* request_matches = match_events.back().get();
    fdds::DataReader* reply_reader =
        subscriber->create_datareader(replies_topic, keyed(fdds::DATAREADER_QOS_DEFAULT, 4096), &caller);
    auto catalog_qos = keyed(fdds::DATAREADER_QOS_DEFAULT, 1000);
    fdds::DataReader* catalog_reader = shared_subscriber->create_datareader(catalog, catalog_qos, &catalog_events);
    if (request_writer == nullptr || reply_reader == nullptr || catalog_reader == nullptr) {
      event("endpoint-refused");
      return 1;
    }
    const auto end = o.duration_s > 0 ? Clock::now() + std::chrono::seconds(o.duration_s) : Clock::time_point::max();
    const std::string payload(o.request_bytes, 'q');
    while (!stopping && Clock::now() < end && (o.replies_wanted == 0 || replies < o.replies_wanted)) {
      if (!request_matches->wait_matched(std::chrono::milliseconds(200))) continue;
      urs::dds::CallRequest request;
      request.request_id(o.space + "/probe/" + std::to_string(++calls));
      request.caller_space(o.space);
      request.service("probe.echo");
      request.operation("echo");
      request.deadline_ms(static_cast<uint32_t>(o.timeout_ms));
      request.payload(std::vector<uint8_t>(payload.begin(), payload.end()));
      const auto sent = Clock::now();
      if (!request_writer->write(&request)) event("request-write-failed " + std::to_string(calls));
      const long size = caller.wait(request.request_id(), sent + std::chrono::milliseconds(o.timeout_ms));
      const auto rtt = std::chrono::duration_cast<std::chrono::microseconds>(Clock::now() - sent).count();
      request_writer->unregister_instance(&request, fdds::HANDLE_NIL);
      if (size >= 0) {
        ++replies;
        rtts_us.push_back(static_cast<long>(rtt));
        if (replies % o.report_every == 0 || replies <= 3) {
          event("reply " + std::to_string(calls) + " " + std::to_string(rtt) + " " + std::to_string(size));
        }
      } else if (!stopping) {
        ++timeouts;
        event("timeout " + std::to_string(calls));
      }
      std::unique_lock lock(stop_mutex);
      stop_changed.wait_for(lock, std::chrono::milliseconds(o.interval_ms), [] { return stopping.load(); });
    }
    std::sort(rtts_us.begin(), rtts_us.end());
    auto pct = [&](double p) {
      return rtts_us.empty() ? 0L : rtts_us[std::min(rtts_us.size() - 1, static_cast<std::size_t>(p * rtts_us.size()))];
    };
    event("summary calls=" + std::to_string(calls) + " replies=" + std::to_string(replies) +
          " timeouts=" + std::to_string(timeouts) + " p50_us=" + std::to_string(pct(0.5)) +
          " p90_us=" + std::to_string(pct(0.9)) + " max_us=" + std::to_string(rtts_us.empty() ? 0 : rtts_us.back()));
    result = replies >= std::max(1L, o.replies_wanted) ? 0 : 3;
  }
  participant->set_listener(nullptr);
  participant->delete_contained_entities();
  factory->delete_participant(participant);
  return result;
}
