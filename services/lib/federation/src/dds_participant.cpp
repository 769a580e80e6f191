#include "dds_participant.hpp"

#include <fastdds/rtps/attributes/ServerAttributes.h>
#include <fastdds/rtps/transport/TCPv4TransportDescriptor.h>
#include <fastdds/rtps/transport/UDPv4TransportDescriptor.h>
#include <fastdds/rtps/transport/shared_mem/SharedMemTransportDescriptor.h>
#include <fastrtps/utils/IPLocator.h>
#include <netdb.h>
#include <netinet/in.h>
#include <spdlog/spdlog.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <fastdds/dds/domain/DomainParticipant.hpp>
#include <fastdds/dds/domain/DomainParticipantFactory.hpp>
#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/publisher/Publisher.hpp>
#include <fastdds/dds/publisher/qos/PublisherQos.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/Subscriber.hpp>
#include <fastdds/dds/subscriber/qos/SubscriberQos.hpp>
#include <fastdds/dds/topic/Topic.hpp>
#include <stdexcept>
#include <vector>

#include "FederationPubSubTypes.h"
#include "dds_qos.hpp"

namespace urs::federation {

namespace fdds = eprosima::fastdds::dds;
namespace rtps = eprosima::fastrtps::rtps;

namespace {

// "HOST" or "HOST:PORT" -> the IPv4 address and port(s) of an initial peer.
std::vector<rtps::Locator_t> peer_locators(const std::string& peer, uint32_t domain) {
  std::string host = peer;
  std::vector<uint16_t> ports;
  const auto colon = peer.rfind(':');
  if (colon != std::string::npos) {
    host = peer.substr(0, colon);
    ports.push_back(static_cast<uint16_t>(std::stoi(peer.substr(colon + 1))));
  } else {
    // The metatraffic unicast ports of participants 0..4 of the domain (RTPS port mapping).
    for (uint32_t id = 0; id < 5; ++id) ports.push_back(static_cast<uint16_t>(7400 + 250 * domain + 10 + 2 * id));
  }
  addrinfo hints{};
  hints.ai_family = AF_INET;
  addrinfo* found = nullptr;
  if (getaddrinfo(host.c_str(), nullptr, &hints, &found) != 0 || found == nullptr) {
    throw std::runtime_error("DDS initial peer '" + peer + "': cannot resolve " + host);
  }
  char address[64] = {};
  getnameinfo(found->ai_addr, found->ai_addrlen, address, sizeof address, nullptr, 0, NI_NUMERICHOST);
  freeaddrinfo(found);
  std::vector<rtps::Locator_t> locators;
  for (uint16_t port : ports) {
    rtps::Locator_t locator;
    rtps::IPLocator::setIPv4(locator, address);
    locator.port = port;
    locators.push_back(locator);
  }
  return locators;
}

// "HOST:PORT" -> a TCPv4 locator: physical port PORT, logical port `logical` (0: negotiated).
rtps::Locator_t tcp_locator(const std::string& address, uint16_t logical, const std::string& what) {
  const auto colon = address.rfind(':');
  if (colon == std::string::npos) throw std::runtime_error("DDS " + what + " '" + address + "': HOST:PORT expected");
  rtps::Locator_t locator = peer_locators(address, 0).front();
  const auto port = static_cast<uint16_t>(locator.port);
  locator.kind = LOCATOR_KIND_TCPv4;
  rtps::IPLocator::setPhysicalPort(locator, port);
  rtps::IPLocator::setLogicalPort(locator, logical);
  return locator;
}

// The announced locator of a listening site whose router forwards another port than the one it
// listens on: its metatraffic (logical port `logical`, 0: Fast DDS's) or user data at the public
// address and port.
rtps::Locator_t announced_locator(const DdsOptions::Tcp& tcp, uint16_t logical) {
  rtps::Locator_t locator;
  locator.kind = LOCATOR_KIND_TCPv4;
  rtps::IPLocator::setIPv4(locator, tcp.public_address);
  rtps::IPLocator::setPhysicalPort(locator, tcp.public_port);
  rtps::IPLocator::setLogicalPort(locator, logical);
  return locator;
}

// Throws std::runtime_error if another socket listens on TCP `port` already: Fast DDS 2.9.1 only
// logs that its acceptor could not bind and goes on with a participant that listens nowhere (the
// other sites then never link). A port left in TIME_WAIT by an earlier run is no refusal
// (SO_REUSEADDR, as the acceptor may take it then).
void check_port_free(uint16_t port) {
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  if (fd < 0) return;  // Fast DDS will say what it can
  const int yes = 1;
  setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof yes);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_addr.s_addr = htonl(INADDR_ANY);
  address.sin_port = htons(port);
  const bool bound = bind(fd, reinterpret_cast<sockaddr*>(&address), sizeof address) == 0;
  const int error = errno;
  close(fd);
  if (!bound && error == EADDRINUSE) {
    throw std::runtime_error("DDS over TCP: cannot listen on port " + std::to_string(port) +
                             ": another process listens there (" + std::strerror(error) + ")");
  }
}

// The link over Fast DDS's TCPv4 transport alone (docs/sites.md). A listening site announces its
// public address: as its WAN address when the router forwards the port it listens on (Fast DDS
// then announces that port), else as its own unicast locators at the public address and port. A
// site that only connects out announces its `public_address` as its WAN address if given: a
// listener that has this site's private address itself takes this site's locators for its own
// without one; on the listener's own host, with one, the two never link (Fast DDS 2.9).
void use_tcp(const DdsOptions& options, fdds::DomainParticipantQos& qos) {
  DdsOptions::Tcp tcp = options.tcp;
  if (tcp.public_port == 0) tcp.public_port = tcp.listen;
  auto transport = std::make_shared<eprosima::fastdds::rtps::TCPv4TransportDescriptor>();
  transport->interfaceWhiteList = options.interfaces;
  transport->enable_tcp_nodelay = true;
  transport->sendBufferSize = options.socket_buffer_bytes;
  transport->receiveBufferSize = options.socket_buffer_bytes;
  if (tcp.listen != 0) {
    if (tcp.public_address.empty()) {
      throw std::runtime_error("DDS over TCP: a listening site must announce its public address");
    }
    rtps::Locator_t check;
    if (!rtps::IPLocator::setIPv4(check, tcp.public_address)) {
      throw std::runtime_error("DDS over TCP: public address '" + tcp.public_address + "' is no IPv4 address");
    }
    check_port_free(tcp.listen);
    transport->add_listener_port(tcp.listen);
    if (tcp.public_port == tcp.listen) {
      transport->set_WAN_address(tcp.public_address);
    } else {
      const bool server = !options.discovery_listen.empty();
      qos.wire_protocol().builtin.metatrafficUnicastLocatorList.push_back(
          announced_locator(tcp, server ? kTcpDiscoveryServerLogicalPort : 0));
      qos.wire_protocol().default_unicast_locator_list.push_back(announced_locator(tcp, 0));
    }
  } else if (!tcp.public_address.empty()) {
    transport->set_WAN_address(tcp.public_address);
  }
  qos.transport().user_transports.push_back(transport);
  std::string peers;
  for (const auto& peer : tcp.connect) peers += (peers.empty() ? "" : ", ") + peer;
  if (tcp.listen != 0) {
    spdlog::info("dds: the link over TCP: listening on port {}, announced at {}:{}{}{}", tcp.listen, tcp.public_address,
                 tcp.public_port, peers.empty() ? "" : "; connecting to ", peers);
  } else {
    spdlog::info("dds: the link over TCP: connecting to {} (not listening)",
                 peers.empty() ? "its discovery servers" : peers);
  }
  for (const auto& peer : tcp.connect) {
    qos.wire_protocol().builtin.initialPeersList.push_back(tcp_locator(peer, 0, "TCP peer"));
  }
}

// Discovery through a Fast DDS discovery server: this participant is the server, or a client of
// the servers given (their GUID prefixes are Fast DDS's defaults for their ids). Over TCP the
// server's metatraffic is on its listening port, logical port kTcpDiscoveryServerLogicalPort.
void use_discovery_server(const DdsOptions& options, fdds::DomainParticipantQos& qos) {
  auto& discovery = qos.wire_protocol().builtin.discovery_config;
  const bool tcp = options.transport == DdsOptions::Transport::kTcp;
  auto one_locator = [tcp](const std::string& address) {
    if (tcp) return tcp_locator(address, kTcpDiscoveryServerLogicalPort, "discovery server");
    if (address.rfind(':') == std::string::npos) {
      throw std::runtime_error("DDS discovery server '" + address + "': HOST:PORT expected");
    }
    return peer_locators(address, 0).front();
  };
  if (!options.discovery_listen.empty()) {
    discovery.discoveryProtocol = rtps::DiscoveryProtocol_t::SERVER;
    if (!rtps::get_server_client_default_guidPrefix(static_cast<int>(options.discovery_server_id),
                                                    qos.wire_protocol().prefix)) {
      throw std::runtime_error("DDS discovery server id " + std::to_string(options.discovery_server_id) +
                               " is out of range");
    }
    auto& metatraffic = qos.wire_protocol().builtin.metatrafficUnicastLocatorList;
    if (!tcp) {
      metatraffic.push_back(one_locator(options.discovery_listen));
    } else if (metatraffic.empty()) {  // else announced at the public address and port (use_tcp)
      rtps::Locator_t locator = one_locator(options.discovery_listen);
      if (rtps::IPLocator::getPhysicalPort(locator) != options.tcp.listen) {
        throw std::runtime_error("DDS discovery server over TCP: it listens on the link's TCP port " +
                                 std::to_string(options.tcp.listen) + ", not on " + options.discovery_listen);
      }
      metatraffic.push_back(locator);
    }
  }
  if (!options.discovery_servers.empty() && options.discovery_listen.empty()) {
    discovery.discoveryProtocol = rtps::DiscoveryProtocol_t::CLIENT;
  }
  for (std::size_t id = 0; id < options.discovery_servers.size(); ++id) {
    eprosima::fastdds::rtps::RemoteServerAttributes server;
    if (!rtps::get_server_client_default_guidPrefix(static_cast<int>(id), server.guidPrefix)) {
      throw std::runtime_error("DDS: at most " + std::to_string(id) + " discovery servers");
    }
    server.metatrafficUnicastLocatorList.push_back(one_locator(options.discovery_servers[id]));
    discovery.m_DiscoveryServers.push_back(server);
  }
}

template <class Qos>
Qos in_partitions(Qos qos, const std::vector<std::string>& partitions) {
  for (const auto& name : partitions) qos.partition().push_back(name.c_str());
  return qos;
}

std::vector<std::string> partitions_of(const fdds::PartitionQosPolicy& policy) {
  std::vector<std::string> names;
  for (const auto& name : policy.names()) names.push_back(name);
  return names;
}

// The refusal of a shared endpoint of `topic` in `partitions`: logged, and thrown.
[[noreturn]] void refused(const std::string& topic, const std::vector<std::string>& partitions,
                          const DdsOptions& options, bool write) {
  const std::string why = options.security.enabled()
                              ? partition_refusal(options.security, options.space, topic, partitions, write)
                              : "dds: DDS refused a " + std::string(write ? "writer" : "reader") + " of " + topic;
  spdlog::error("{}", why);
  throw std::runtime_error(why);
}

}  // namespace

SharedPartitions shared_partitions(const DdsOptions& options) {
  if (!options.security.enabled()) return {};
  try {
    // Every shared topic has the same grant (deploy/pki.sh); the catalog's stands for them.
    std::vector<std::string> read = read_partitions(topic_grant(options.security, "urs/catalog", false));
    return {{options.space}, std::move(read)};
  } catch (const std::exception& e) {
    throw std::runtime_error(std::string("DDS security: ") + e.what());
  }
}

fdds::Publisher* create_shared_publisher(fdds::DomainParticipant* participant,
                                         const std::vector<std::string>& partitions) {
  fdds::Publisher* made = participant->create_publisher(in_partitions(fdds::PUBLISHER_QOS_DEFAULT, partitions));
  if (made == nullptr) throw std::runtime_error("DDS: cannot create a publisher");
  return made;
}

fdds::Subscriber* create_shared_subscriber(fdds::DomainParticipant* participant,
                                           const std::vector<std::string>& partitions) {
  fdds::Subscriber* made = participant->create_subscriber(in_partitions(fdds::SUBSCRIBER_QOS_DEFAULT, partitions));
  if (made == nullptr) throw std::runtime_error("DDS: cannot create a subscriber");
  return made;
}

fdds::DataWriter* create_shared_writer(fdds::Publisher* publisher, fdds::Topic* topic, const fdds::DataWriterQos& qos,
                                       const DdsOptions& options) {
  fdds::DataWriter* made = publisher->create_datawriter(topic, qos);
  if (made == nullptr) refused(topic->get_name(), partitions_of(publisher->get_qos().partition()), options, true);
  return made;
}

fdds::DataReader* create_shared_reader(fdds::Subscriber* subscriber, fdds::Topic* topic, const fdds::DataReaderQos& qos,
                                       fdds::DataReaderListener* listener, const DdsOptions& options) {
  fdds::DataReader* made = subscriber->create_datareader(topic, qos, listener);
  if (made == nullptr) refused(topic->get_name(), partitions_of(subscriber->get_qos().partition()), options, false);
  return made;
}

LinkParticipant::LinkParticipant()
    : entry_type(new dds::ServiceEntryPubSubType()),
      interface_type(new dds::InterfaceDescriptionPubSubType()),
      request_type(new dds::CallRequestPubSubType()),
      reply_type(new dds::CallReplyPubSubType()) {}

void LinkParticipant::join(const DdsOptions& options, fdds::DomainParticipantListener* listener) {
  auto* factory = fdds::DomainParticipantFactory::get_instance();
  factory->load_profiles();  // an XML default profile's settings, but for the transports set below
  fdds::DomainParticipantQos qos = factory->get_default_participant_qos();
  qos.name("urs-bridge/" + options.space + "/" + options.bridge);
  // A participant that stops announcing itself (dead process, cut network) is dropped after its
  // lease; its entries end earlier, with its writers' liveliness (`lease`). Announced four times
  // a `lease`, so that a peer that dropped it finds it again quickly.
  qos.wire_protocol().builtin.discovery_config.leaseDuration =
      link_qos::duration(std::max(options.participant_lease, options.lease));
  qos.wire_protocol().builtin.discovery_config.leaseDuration_announcementperiod = link_qos::duration(options.lease / 4);
  // Only the transports below: builtin ones, or those of an XML default profile (the images'
  // UDP-only profile for the devices' domain), would announce (and send to) UDP locators a TCP
  // link's other sites cannot reach, and would open UDP sockets where none may be used.
  qos.transport().use_builtin_transports = false;
  qos.transport().user_transports.clear();
  qos.transport().send_socket_buffer_size = options.socket_buffer_bytes;
  qos.transport().listen_socket_buffer_size = options.socket_buffer_bytes;
  if (options.transport == DdsOptions::Transport::kTcp) {
    use_tcp(options, qos);
  } else {
    auto udp = std::make_shared<eprosima::fastdds::rtps::UDPv4TransportDescriptor>();
    udp->interfaceWhiteList = options.interfaces;
    udp->sendBufferSize = options.socket_buffer_bytes;
    udp->receiveBufferSize = options.socket_buffer_bytes;
    qos.transport().user_transports.push_back(udp);
    if (!options.udp_only) {
      auto shm = std::make_shared<eprosima::fastdds::rtps::SharedMemTransportDescriptor>();
      shm->segment_size(options.shm_segment_bytes);
      qos.transport().user_transports.push_back(shm);
    }
    for (const auto& peer : options.initial_peers) {
      for (const auto& locator : peer_locators(peer, options.domain)) {
        qos.wire_protocol().builtin.initialPeersList.push_back(locator);
      }
    }
  }
  use_discovery_server(options, qos);
  if (!options.interfaces.empty()) {
    std::string addresses;
    for (const auto& address : options.interfaces) addresses += (addresses.empty() ? "" : ", ") + address;
    spdlog::info("dds: the link's {} transport uses only the interfaces {}{}",
                 options.transport == DdsOptions::Transport::kTcp ? "TCP" : "UDP", addresses,
                 options.transport == DdsOptions::Transport::kUdp && !options.udp_only
                     ? " (shared memory between bridges of this host besides)"
                     : "");
  }
  if (options.security.enabled()) {
    // Checked here: Fast DDS would say only "initialization error" for any bad file.
    const std::vector<std::string> problems = check_dds_security(options.security, options.space);
    if (!problems.empty()) {
      std::string text;
      for (const auto& problem : problems) text += "\n  " + problem;
      throw std::runtime_error("DDS security: cannot join domain " + std::to_string(options.domain) + ":" + text);
    }
    for (const auto& [name, value] : dds_security_properties(options.security)) {
      qos.properties().properties().emplace_back(name, value);
    }
  }
  participant_ = factory->create_participant(options.domain, qos, listener, fdds::StatusMask::none());
  if (participant_ == nullptr) {
    throw std::runtime_error("DDS: cannot join domain " + std::to_string(options.domain) +
                             (options.security.enabled() ? " with DDS security (see Fast DDS's log above)" : ""));
  }
  try {
    publisher_ = participant_->create_publisher(fdds::PUBLISHER_QOS_DEFAULT);
    subscriber_ = participant_->create_subscriber(fdds::SUBSCRIBER_QOS_DEFAULT);
    if (publisher_ == nullptr || subscriber_ == nullptr) throw std::runtime_error("DDS: cannot create a publisher");
    shared_publisher_ = publisher_;
    shared_subscriber_ = subscriber_;
    if (options.security.enabled()) {
      const SharedPartitions partitions = shared_partitions(options);
      shared_publisher_ = create_shared_publisher(participant_, partitions.write);
      shared_subscriber_ = create_shared_subscriber(participant_, partitions.read);
      std::string reads;
      for (const auto& name : partitions.read) reads += (reads.empty() ? "" : ", ") + name;
      spdlog::info("dds: {} shares its catalog, descriptions and state in partition {} and reads them in {}",
                   options.space, options.space, reads);
    }
    for (auto* type : {&entry_type, &interface_type, &request_type, &reply_type}) {
      if (type->register_type(participant_) != ReturnCode_t::RETCODE_OK) {
        throw std::runtime_error("DDS: cannot register type " + type->get_type_name());
      }
    }
  } catch (...) {
    leave();
    throw;
  }
}

void LinkParticipant::leave() {
  if (participant_ == nullptr) return;
  participant_->set_listener(nullptr);
  participant_->delete_contained_entities();
  fdds::DomainParticipantFactory::get_instance()->delete_participant(participant_);
  participant_ = nullptr;
  publisher_ = nullptr;
  subscriber_ = nullptr;
  shared_publisher_ = nullptr;
  shared_subscriber_ = nullptr;
  std::lock_guard lock(mutex_);
  topics_.clear();
}

fdds::Topic* LinkParticipant::topic(const std::string& name, fdds::TypeSupport& type) {
  std::lock_guard lock(mutex_);
  auto it = topics_.find(name);
  if (it != topics_.end()) return it->second;
  fdds::Topic* made = participant_->create_topic(name, type.get_type_name(), fdds::TOPIC_QOS_DEFAULT);
  if (made == nullptr) throw std::runtime_error("DDS: cannot create topic " + name);
  topics_[name] = made;
  return made;
}

}  // namespace urs::federation
