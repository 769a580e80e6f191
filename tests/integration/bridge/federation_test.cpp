// Two spaces linked only over DDS (real Fast DDS participants, UDP only, as between containers):
// "jp" is an RT-Middleware space (omniNames, urs-rtc-manager with a Diagnostic RTC, urs-bridge
// with no CAMUS server) and "kr" a CAMUS space (urs-camus-server, urs-sam with the diagnostic
// agent, urs-bridge with no naming service). Each space's services are callable from the other
// under the other space's prefix; a dead bridge's services vanish within the lease and return
// with it; a restarted CAMUS server gets the imported services back; filters and loop prevention
// keep the catalogs as configured. The spaces also share state: jp's RTC lifecycle states and
// robot poses reach kr's context, kr's agents, context entries and events reach any DDS reader
// (here a third "space" observing the link), and a lost bridge's state ends with it. A reader
// knowing none of URSLink's types reads every topic of the link with the types announced at run
// time.

#include "Federation.h"

#include <arpa/inet.h>
#include <fastrtps/utils/IPLocator.h>
#include <google/protobuf/descriptor.pb.h>
#include <google/protobuf/struct.pb.h>
#include <google/protobuf/util/json_util.h>
#include <google/protobuf/wrappers.pb.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <condition_variable>
#include <csignal>
#include <cstring>
#include <fastdds/dds/domain/DomainParticipant.hpp>
#include <fastdds/dds/domain/DomainParticipantFactory.hpp>
#include <fastdds/dds/domain/DomainParticipantListener.hpp>
#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/publisher/Publisher.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>
#include <fastdds/dds/subscriber/Subscriber.hpp>
#include <fastdds/dds/topic/Topic.hpp>
#include <fastdds/dds/topic/TypeSupport.hpp>
#include <filesystem>
#include <fstream>
#include <future>
#include <iostream>
#include <map>
#include <mutex>
#include <set>
#include <sstream>
#include <thread>
#include <vector>

#include "Diagnostic.pb.h"
#include "FederationPubSubTypes.h"
#include "SpaceState.h"
#include "SpaceStatePubSubTypes.h"
#include "bridge_fixture.hpp"
#include "camus.pb.h"
#include "certificates.hpp"
#include "dds_domain.hpp"
#include "urs/corba_agent/corba_proxy.hpp"
#include "urs/federation/state_link.hpp"
#include "urs/schema/schema.hpp"
#include "urs/world/world.hpp"

namespace urs::test {
namespace {

using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;
namespace gp = google::protobuf;

constexpr auto kLease = 1500ms;
// How long a lost space's services stay offered, unreachable (dds.hold_lost_ms).
constexpr auto kHold = 4500ms;
// How long a bridge killed and started again may take to link again: on a secured link its new
// participant passes a new handshake first, which in one CI run at full load took 19 s.
constexpr auto kRelink = 60s;

// Run twice: on a plain link, and on a link secured with DDS-Security (a federation PKI made by
// deploy/pki.sh once for the program: kr and jp, each granted calls to the other, "obs", the
// tests' own observer, granted none, and "spy", the tests' own caller, granted calls to jp).
class Federation : public BridgeSpaceTest, public ::testing::WithParamInterface<bool> {
 protected:
  static void SetUpTestSuite() {
    pki_ = new std::string(make_temp_dir("federation-pki"));
    ASSERT_NO_THROW(run_pki({{"init", *pki_},
                             {"governance", *pki_},
                             {"member", *pki_, "kr", "--calls", "jp"},
                             {"member", *pki_, "jp", "--calls", "kr"},
                             {"member", *pki_, "obs"},
                             {"member", *pki_, "spy", "--calls", "jp"}}));
  }
  static void TearDownTestSuite() {
    std::filesystem::remove_all(*pki_);
    delete pki_;
  }
  virtual bool secured() const { return GetParam(); }
  // The files of the tests' own participants on the link: none on a plain link.
  federation::DdsSecurity observer_security() const {
    return secured() ? federation::security_from_folder(*pki_, "obs") : federation::DdsSecurity{};
  }
  // The link options of member "spy", the tests' own caller (space spy).
  federation::DdsOptions spy_options() const {
    federation::DdsOptions options;
    options.domain = static_cast<uint32_t>(domain_);
    options.space = "spy";
    options.bridge = "spy";
    options.lease = kLease;
    options.udp_only = true;
    if (secured()) options.security = federation::security_from_folder(*pki_, "spy");
    return options;
  }

  void SetUp() override {
    space_ = "kr";
    BridgeSpaceTest::SetUp();
    if (HasFatalFailure()) return;
    domain_ = static_cast<int>(domains_[0]);  // tests running side by side stay apart
    start_manager("m", "jphost", "components:\n  - type: Diagnostic\n  - type: Diagnostic\n    instance: Secret0\n");
    start_jp();
    start_kr();
  }

  void start_kr(const std::string& discovery = "", const std::string& context_allow = "\"room.*\"",
                std::vector<std::string> wrapper = {}) {
    kr_ = launch_bridge("bridge-kr",
                        "name: bridge-kr\n" + dds(discovery, kr_transport()) +
                            "  export: {allow: [\"*\"], deny: []}\n"
                            "  import: {as_rtc: \"\"}\n"
                            "  state: {events: [\"alarm/#\"], context: {allow: [" +
                            context_allow + "]}}\n",
                        {"--server", server_address_}, "", std::move(wrapper));
  }

  void TearDown() override {
    if (HasFailure()) {
      std::cerr << "---- bridge-jp log\n"
                << (jp_ ? jp_->log() : "") << "---- bridge-kr log\n"
                << (kr_ ? kr_->log() : "");
    }
    jp_.reset();
    kr_.reset();
    BridgeSpaceTest::TearDown();
  }

  std::string dds(const std::string& discovery, const std::string& transport) const {
    return "dds:\n  domain: " + std::to_string(domain_) + "\n  lease_ms: " + std::to_string(kLease.count()) +
           "\n  hold_lost_ms: " + std::to_string(kHold.count()) + "\n" + transport +
           (secured() ? "  security: {pki: \"" + *pki_ + "\"}\n" : "") + discovery;
  }
  // The transport settings of each space's bridge (dds.udp_only, dds.transport, dds.tcp).
  virtual std::string jp_transport() const { return "  udp_only: true\n"; }
  virtual std::string kr_transport() const { return "  udp_only: true\n"; }

  static std::string* pki_;

  void start_jp(const std::string& discovery = "") {
    jp_ = launch_bridge("bridge-jp",
                        "name: bridge-jp\n"
                        "rt_to_camus:\n"
                        "  poll_ms: 100\n"
                        "  providers:\n"
                        "    - {match: \"*\", name: \"rt.{instance}\", deadline_ms: 5000}\n" +
                            dds(discovery, jp_transport()) + jp_export() +
                            "  state: {period_ms: 100, poses: {domain: " + std::to_string(devices_domain()) +
                            ", source: ground_truth, robots: [robot1], period_ms: 20}}\n",
                        {"--naming", naming_->address(), "--host", "jphost"}, "jp");
  }

  // What jp's bridge exports, and to whom (dds.export, dds.audit).
  virtual std::string jp_export() { return "  export: {deny: [\"rt.Secret*\"]}\n"; }

  // `text` echoed by `service` from kr's Planet client.
  void expect_echo(const std::string& service, const std::string& text) {
    URS::Diagnostic_echo_Request echo;
    echo.set_text(text);
    const Observed echoed = call(service, "echo", echo);
    ASSERT_EQ(echoed.status, planet::OK) << echoed.message;
    URS::Diagnostic_echo_Reply reply;
    ASSERT_TRUE(reply.ParseFromString(echoed.payload));
    EXPECT_EQ(reply.result(), text);
  }

  // A 921,600-byte reply (an image's worth) from `service`'s blob, whole and in order.
  void expect_image(const std::string& service) {
    URS::Diagnostic_blob_Request blob;
    blob.set_size(921600);
    const auto started = Clock::now();
    const Observed image = call(service, "blob", blob);
    std::cout << "921600-byte reply across spaces: "
              << std::chrono::duration_cast<std::chrono::microseconds>(Clock::now() - started).count() << " us\n";
    ASSERT_EQ(image.status, planet::OK) << image.message;
    URS::Diagnostic_blob_Reply bytes;
    ASSERT_TRUE(bytes.ParseFromString(image.payload));
    ASSERT_EQ(bytes.result().size(), 921600u);
    for (std::size_t i = 0; i < bytes.result().size(); i += 4099) {
      ASSERT_EQ(static_cast<unsigned char>(bytes.result()[i]), i % 251) << "byte " << i;
    }
  }

  // kr's CAMUS server killed and started again on its port, with its data.
  void restart_server() {
    const std::string port = server_address_.substr(server_address_.rfind(':') + 1);
    server_->kill9();
    std::vector<std::string> argv{
        URS_SERVER_BIN, "--space",      space_,           "--listen", "127.0.0.1:" + port,
        "--data-dir",   dir_ + "/data", "--heartbeat-ms", "200",      "--heartbeat-timeout-ms",
        "1000"};
    const std::vector<std::string> credentials = credentials_args();
    argv.insert(argv.end(), credentials.begin(), credentials.end());
    server_ = std::make_unique<Process>(argv, dir_ + "/server2.log");
  }

  // A UDP (TCP) port nothing listens on now.
  static uint16_t free_udp_port(int type = SOCK_DGRAM) {
    const int fd = socket(AF_INET, type, 0);
    sockaddr_in address{};
    address.sin_family = AF_INET;
    address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    bind(fd, reinterpret_cast<sockaddr*>(&address), sizeof address);
    socklen_t length = sizeof address;
    getsockname(fd, reinterpret_cast<sockaddr*>(&address), &length);
    close(fd);
    return ntohs(address.sin_port);
  }

  uint32_t devices_domain() const { return domains_[1]; }

  // kr's context entry `key` (its value), or nullopt if it has none.
  std::optional<google::protobuf::Value> context(const std::string& key) {
    camus::ContextGetRequest request;
    request.set_key(key);
    const auto r = planet_->call("camus.context", "Get", request.SerializeAsString(), 2s);
    camus::ContextEntry entry;
    if (!r.ok() || !entry.ParseFromString(r.payload)) return std::nullopt;
    return entry.value();
  }
  std::string context_field(const std::string& key, const std::string& field) {
    const auto value = context(key);
    if (!value || !value->has_struct_value()) return "";
    const auto& fields = value->struct_value().fields();
    auto it = fields.find(field);
    if (it == fields.end()) return "";
    return it->second.has_string_value() ? it->second.string_value() : std::to_string(it->second.number_value());
  }

  Observed call(const std::string& service, const std::string& operation, const gp::Message& request,
                std::chrono::milliseconds deadline = 5s) {
    const auto r = planet_->call(service, operation, request.SerializeAsString(), deadline);
    return {r.status, r.payload, r.exception_type, r.message};
  }

  const DdsDomains domains_{2};  // the link's and jp's devices'
  int domain_ = 0;
  std::unique_ptr<Process> jp_;
  std::unique_ptr<Process> kr_;
};

std::string* Federation::pki_ = nullptr;

INSTANTIATE_TEST_SUITE_P(Link, Federation, ::testing::Values(false, true),
                         [](const ::testing::TestParamInfo<bool>& info) { return info.param ? "Secured" : "Plain"; });

// Tests of a plain link only (another vendor's tool reading it; the discovery server).
class PlainFederation : public Federation {
 protected:
  bool secured() const override { return false; }
};

TEST_P(Federation, EachSpacesServicesAreCallableFromTheOther) {
  ASSERT_TRUE(wait_for_service("jp/rt.Diagnostic0", 20s)) << kr_->log() << jp_->log();
  EXPECT_NE(listed("jp/rt.Diagnostic0").find("dds:jp/rt.Diagnostic0"), std::string::npos);

  // kr's CAMUS client -> kr server -> bridge-kr -DDS-> bridge-jp -CORBA-> jp's RTC.
  ASSERT_NO_FATAL_FAILURE(expect_echo("jp/rt.Diagnostic0", "こんにちは from kr"));

  // bridge-kr passes a call's bytes on unparsed: bridge-jp refuses what is no request of the
  // operation, naming the service as jp calls it.
  const auto garbage = planet_->call("jp/rt.Diagnostic0", "echo", std::string("\xff\xff\xff garbage", 11), 5s);
  EXPECT_EQ(garbage.status, planet::BAD_ARGUMENTS) << garbage.message;
  EXPECT_EQ(garbage.message, "payload of rt.Diagnostic0.echo is not a valid URS.Diagnostic_echo_Request");

  ASSERT_NO_FATAL_FAILURE(expect_image("jp/rt.Diagnostic0"));  // an image-sized reply crosses whole

  URS::Diagnostic_fail_Request fail;
  fail.set_reason("wheel stuck");
  fail.set_code(12);
  const Observed raised = call("jp/rt.Diagnostic0", "fail", fail);
  EXPECT_EQ(raised.status, planet::USER_EXCEPTION);
  EXPECT_EQ(raised.exception_type, "URS.Failure");
  URS::Failure failure;
  ASSERT_TRUE(failure.ParseFromString(raised.payload));
  EXPECT_EQ(failure.reason(), "wheel stuck");
  EXPECT_EQ(failure.code(), 12);

  URS::Diagnostic_sleep_Request sleep;  // the caller's deadline crosses the border
  sleep.set_ms(3000);
  EXPECT_EQ(call("jp/rt.Diagnostic0", "sleep", sleep, 400ms).status, planet::DEADLINE_EXCEEDED);

  // The filtered service is not offered; nothing imported is offered back.
  EXPECT_TRUE(listed("jp/rt.Secret0").empty());
  const auto all = urs({"ls"});
  EXPECT_EQ(all.out.find("kr/"), std::string::npos) << all.out;
  EXPECT_EQ(all.out.find("jp/kr"), std::string::npos) << all.out;

  // jp's side: kr's diag is an RTC in jp's naming service (bridge-jp imports as RTCs), and a
  // CORBA consumer calling it reaches kr's agent: DII -> bridge-jp -DDS-> bridge-kr -> SAM.
  ASSERT_TRUE(wait_until([&] { return bound("jphost.host_cxt/kr_diag.rtc"); }, 20s)) << jp_->log();
  CORBA::Object_var provider =
      provided_object("jphost.host_cxt/kr_diag.rtc", "diagnostic", "URS::Diagnostic", "diagnostic");
  ASSERT_FALSE(CORBA::is_nil(provider));
  corba_agent::CorbaProxyAgent consumer(
      test_orb().orb(), provider, *URS::Diagnostic_echo_Request::descriptor()->file()->FindServiceByName("Diagnostic"));
  agent::CallContext ctx;
  ctx.deadline = Clock::now() + 5s;
  URS::Diagnostic_echo_Request from_jp;
  from_jp.set_text("from jp's RT side");
  URS::Diagnostic_echo_Reply to_jp;
  const agent::Outcome outcome = consumer.invoke(*consumer.interface().FindMethodByName("echo"), from_jp, to_jp, ctx);
  EXPECT_EQ(outcome.status, call::Status::OK) << outcome.message;
  EXPECT_EQ(to_jp.result(), "from jp's RT side");
}

// A call to a space none of whose bridges is alive: refused at once, naming the space, while its
// services are held (dds.hold_lost_ms); once they have left, UNKNOWN_SERVICE.
TEST_P(Federation, ADeadBridgesSpaceIsUnreachableThenItsServicesLeaveAndReturnWithIt) {
  ASSERT_TRUE(wait_for_service("jp/rt.Diagnostic0", 20s)) << kr_->log();
  // `urs spaces`: jp, reachable, its services brought by bridge-kr.
  auto space_line = [&](const std::string& space) {
    const CommandResult r = urs({"spaces"});
    std::istringstream lines(r.out);
    for (std::string line; std::getline(lines, line);) {
      if (line.compare(0, space.size() + 1, space + " ") == 0) return line;
    }
    return std::string();
  };
  const std::string reachable = space_line("jp");
  EXPECT_NE(reachable.find(" reachable "), std::string::npos) << reachable;
  EXPECT_NE(reachable.find("bridge-kr"), std::string::npos) << reachable;
  jp_->kill9();
  const auto killed = Clock::now();
  URS::Diagnostic_echo_Request echo;
  // Until the lease has passed a call may still go out (and fail with PROVIDER_GONE or UNAVAILABLE
  // as its request finds no bridge); never UNKNOWN_SERVICE.
  Observed refused;
  std::set<int> seen;
  ASSERT_TRUE(wait_until(
      [&] {
        refused = call("jp/rt.Diagnostic0", "echo", echo, 1s);
        seen.insert(refused.status);
        return refused.status == planet::UNAVAILABLE &&
               refused.message.find("space jp is unreachable") != std::string::npos;
      },
      kLease * 4))
      << refused.status << " " << refused.message << "\n"
      << kr_->log();
  const auto unreachable = Clock::now() - killed;
  std::cout << "jp unreachable from kr " << std::chrono::duration_cast<std::chrono::milliseconds>(unreachable).count()
            << " ms after the kill (lease " << kLease.count() << " ms): " << refused.message << "\n";
  EXPECT_EQ(seen.count(planet::UNKNOWN_SERVICE), 0u);
  EXPECT_EQ(seen.count(planet::OK), 0u);
  EXPECT_TRUE(wait_until([&] { return listed("jp/rt.Diagnostic0").find("unreachable") != std::string::npos; }, 5s))
      << listed("jp/rt.Diagnostic0");
  EXPECT_NE(space_line("jp").find(" unreachable "), std::string::npos) << space_line("jp");

  // The hold passes: the service leaves, and a call says it is not there.
  ASSERT_TRUE(wait_service_gone("jp/rt.Diagnostic0", kHold + 10s)) << kr_->log();
  const Observed failed = call("jp/rt.Diagnostic0", "echo", echo, 5s);
  EXPECT_EQ(failed.status, planet::UNKNOWN_SERVICE) << failed.message;

  start_jp();  // a new participant: on a secured link, a new handshake too
  ASSERT_TRUE(wait_for_service("jp/rt.Diagnostic0", kRelink)) << kr_->log();
  echo.set_text("back");
  const Observed back = call("jp/rt.Diagnostic0", "echo", echo);
  EXPECT_EQ(back.status, planet::OK) << back.message;

  // kr's CAMUS server dies and comes back on its port: bridge-kr registers the imports again.
  restart_server();
  ASSERT_TRUE(wait_for_service("jp/rt.Diagnostic0", 20s)) << kr_->log();
  ASSERT_TRUE(planet_->wait_connected(10s));
  echo.set_text("after the server restart");
  const Observed again = call("jp/rt.Diagnostic0", "echo", echo);
  EXPECT_EQ(again.status, planet::OK) << again.message;
}

// A bridge paused (SIGSTOP) long enough to be lost, and back within the hold: meanwhile its
// space's calls are refused naming it; its stand-in in kr is never withdrawn nor offered again.
TEST_P(Federation, ASpaceBackWithinTheHoldFindsItsServicesWhereTheyWere) {
  ASSERT_TRUE(wait_for_service("jp/rt.Diagnostic0", 20s)) << kr_->log();
  expect_echo("jp/rt.Diagnostic0", "before");
  jp_->signal(SIGSTOP);
  URS::Diagnostic_echo_Request echo;
  Observed refused;
  std::set<int> seen;
  const bool lost = wait_until(
      [&] {
        refused = call("jp/rt.Diagnostic0", "echo", echo, 1s);
        seen.insert(refused.status);
        return refused.status == planet::UNAVAILABLE &&
               refused.message.find("space jp is unreachable") != std::string::npos;
      },
      kLease * 4);
  jp_->signal(SIGCONT);
  ASSERT_TRUE(lost) << refused.status << " " << refused.message << "\n" << kr_->log();
  EXPECT_EQ(seen.count(planet::UNKNOWN_SERVICE), 0u);
  Observed back;
  EXPECT_TRUE(wait_until(
      [&] {
        back = call("jp/rt.Diagnostic0", "echo", echo, 2s);
        return back.status == planet::OK;
      },
      20s))
      << back.status << " " << back.message;
  EXPECT_TRUE(wait_until([&] { return listed("jp/rt.Diagnostic0").find("unreachable") == std::string::npos; }, 10s))
      << listed("jp/rt.Diagnostic0");
  const std::string log = kr_->log();
  EXPECT_EQ(log.find("withdrawing jp/rt.Diagnostic0"), std::string::npos) << log;
  EXPECT_NE(log.find("space jp is unreachable: jp/rt.Diagnostic0 stays offered"), std::string::npos) << log;
}

// Sites that pass no multicast: bridge-jp is a Fast DDS discovery server, bridge-kr its client
// (a client discovers nothing but through its servers), and the spaces link as before. On a plain
// link only: Fast DDS 2.9's discovery server and DDS-Security do not go together (the
// configuration refuses it, config_test).
TEST_F(PlainFederation, SpacesLinkThroughADiscoveryServer) {
  jp_.reset();
  kr_.reset();
  ASSERT_TRUE(wait_service_gone("jp/rt.Diagnostic0", 15s));
  const std::string server = "127.0.0.1:" + std::to_string(free_udp_port());
  start_jp("  discovery: {listen: \"" + server + "\"}\n");
  start_kr("  discovery: {servers: [\"" + server + "\"]}\n");
  ASSERT_TRUE(wait_for_service("jp/rt.Diagnostic0", 20s)) << jp_->log() << kr_->log();
  ASSERT_NO_FATAL_FAILURE(expect_echo("jp/rt.Diagnostic0", "through the discovery server"));
  EXPECT_NE(kr_->log().find("discovery server"), std::string::npos) << kr_->log();
}

// The link over TCP only (dds.transport: tcp, docs/sites.md), on loopback: bridge-jp listens on
// one TCP port and announces 127.0.0.1 as its public address, bridge-kr connects out to it;
// neither has a UDP or shared-memory transport. Plain and secured.
class TcpFederation : public Federation {
 protected:
  void SetUp() override {
    tcp_port_ = free_udp_port(SOCK_STREAM);
    kr_connects_to_ = tcp_port_;
    Federation::SetUp();
  }
  std::string jp_transport() const override {
    return "  transport: tcp\n  tcp: {listen: " + std::to_string(tcp_port_) + ", public: \"127.0.0.1" +
           (jp_public_port_ == 0 ? "" : ":" + std::to_string(jp_public_port_)) + "\"}\n";
  }
  std::string kr_transport() const override {
    if (kr_connects_to_ == 0) return "  transport: tcp\n";  // its discovery server's address only
    return "  transport: tcp\n  tcp: {connect: [\"127.0.0.1:" + std::to_string(kr_connects_to_) + "\"]" + kr_tcp_more_ +
           "}\n";
  }
  uint16_t tcp_port_ = 0;
  uint16_t jp_public_port_ = 0;  // the port jp announces (0: tcp_port_), as a router forwarding another one
  uint16_t kr_connects_to_ = 0;
  std::string kr_tcp_more_;  // more of kr's dds.tcp, ", key: value"
};

INSTANTIATE_TEST_SUITE_P(Link, TcpFederation, ::testing::Values(false, true),
                         [](const ::testing::TestParamInfo<bool>& info) { return info.param ? "Secured" : "Plain"; });

class PlainTcpFederation : public TcpFederation {
 protected:
  bool secured() const override { return false; }
};

// The catalog, a call and a 921,600-byte reply through jp's one TCP port; and through it only:
// bridge-kr connecting to a port nobody listens on never sees jp.
TEST_P(TcpFederation, TheSpacesLinkThroughTheListenersPortOnly) {
  // A first link over TCP can take Fast DDS's connection retries on a loaded machine: a wider wait.
  // On a loaded machine Fast DDS 2.9.1's TCP negotiation can also stall for good (the connection
  // up, nothing flowing: docs/sites.md, Limits): bridge-kr then joins again after
  // dds.tcp.rejoin_after_ms (20 s), which this wait covers twice.
  ASSERT_TRUE(wait_for_service("jp/rt.Diagnostic0", 75s)) << kr_->log() << jp_->log();
  ASSERT_NO_FATAL_FAILURE(expect_echo("jp/rt.Diagnostic0", "over TCP"));
  ASSERT_NO_FATAL_FAILURE(expect_image("jp/rt.Diagnostic0"));
  EXPECT_NE(jp_->log().find("the link over TCP: listening on port " + std::to_string(tcp_port_) +
                            ", announced at 127.0.0.1:" + std::to_string(tcp_port_)),
            std::string::npos)
      << jp_->log();
  EXPECT_NE(kr_->log().find("the link over TCP: connecting to 127.0.0.1:" + std::to_string(tcp_port_)),
            std::string::npos)
      << kr_->log();

  kr_.reset();
  ASSERT_TRUE(wait_service_gone("jp/rt.Diagnostic0", 15s));
  kr_connects_to_ = free_udp_port(SOCK_STREAM);
  start_kr();
  EXPECT_FALSE(wait_for_service("jp/rt.Diagnostic0", 6s)) << "linked without connecting to jp's port";
}

// A TCP relay on loopback whose first connection carries nothing, for good (what Fast DDS 2.9.1's
// stalled negotiation leaves: docs/sites.md, Limits): it takes the connection and never answers
// nor forwards it; every later one it forwards to `to`, both ways.
class FirstConnectionSilentRelay {
 public:
  explicit FirstConnectionSilentRelay(uint16_t to) : to_(to) {
    listener_ = socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    sockaddr_in address = loopback(0);
    bind(listener_, reinterpret_cast<sockaddr*>(&address), sizeof address);
    listen(listener_, 8);
    socklen_t length = sizeof address;
    getsockname(listener_, reinterpret_cast<sockaddr*>(&address), &length);
    port_ = ntohs(address.sin_port);
    thread_ = std::thread([this] { run(); });
  }
  ~FirstConnectionSilentRelay() {
    stopping_ = true;
    thread_.join();
    for (const int fd : fds_) close(fd);
    close(listener_);
  }
  uint16_t port() const { return port_; }
  int accepted() const { return accepted_; }

 private:
  static sockaddr_in loopback(uint16_t port) {
    sockaddr_in address{};
    address.sin_family = AF_INET;
    address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    address.sin_port = htons(port);
    return address;
  }
  // One thread polls the listener and every forwarded pair (the silent one is never read).
  void run() {
    std::map<int, int> peer;  // each forwarded socket -> the other end of its pair
    while (!stopping_) {
      std::vector<pollfd> fds{{listener_, POLLIN, 0}};
      for (const auto& [fd, other] : peer) fds.push_back({fd, POLLIN, 0});
      if (poll(fds.data(), fds.size(), 100) <= 0) continue;
      if (fds[0].revents & POLLIN) {
        const int client = accept4(listener_, nullptr, nullptr, SOCK_CLOEXEC);
        if (client >= 0) {
          fds_.push_back(client);
          if (accepted_++ > 0) {
            const int server = socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
            sockaddr_in address = loopback(to_);
            fds_.push_back(server);
            if (connect(server, reinterpret_cast<sockaddr*>(&address), sizeof address) == 0) {
              peer[client] = server;
              peer[server] = client;
            }
          }
        }
      }
      for (std::size_t i = 1; i < fds.size(); ++i) {
        if (!(fds[i].revents & (POLLIN | POLLHUP | POLLERR))) continue;
        const auto pair = peer.find(fds[i].fd);
        if (pair == peer.end()) continue;
        char buffer[65536];
        const ssize_t n = read(fds[i].fd, buffer, sizeof buffer);
        if (n <= 0) {  // one end closed: the pair ends
          shutdown(pair->second, SHUT_RDWR);
          peer.erase(pair->second);
          peer.erase(fds[i].fd);
          continue;
        }
        for (ssize_t sent = 0; sent < n;) {
          const ssize_t w = send(pair->second, buffer + sent, static_cast<std::size_t>(n - sent), MSG_NOSIGNAL);
          if (w <= 0) break;
          sent += w;
        }
      }
    }
  }

  const uint16_t to_;
  int listener_ = -1;
  uint16_t port_ = 0;
  std::atomic<bool> stopping_{false};
  std::atomic<int> accepted_{0};
  std::vector<int> fds_;  // every socket accepted or opened, closed at the end
  std::thread thread_;
};

// bridge-kr reaches bridge-jp only through a relay (jp announces the relay's port, as behind a
// router forwarding it) whose first connection carries nothing: without dds.tcp.rejoin_after_ms
// kr stays on that connection and never links; with it, it joins the link again, connects anew
// and links.
TEST_F(PlainTcpFederation, AConnectionThatCarriesNothingIsLeftAndTheLinkJoinedAgain) {
  // jp behind a new relay (on a port of its own: the last one may be closing still), kr connecting to it.
  auto start_behind = [&](FirstConnectionSilentRelay& relay, const std::string& rejoin_after_ms) {
    jp_public_port_ = kr_connects_to_ = relay.port();
    start_jp();
    kr_tcp_more_ = ", rejoin_after_ms: " + rejoin_after_ms;
    start_kr();
  };
  kr_.reset();
  jp_.reset();
  ASSERT_TRUE(wait_service_gone("jp/rt.Diagnostic0", 15s));
  {
    tcp_port_ = free_udp_port(SOCK_STREAM);
    FirstConnectionSilentRelay relay(tcp_port_);
    start_behind(relay, "0");
    EXPECT_FALSE(wait_for_service("jp/rt.Diagnostic0", 15s)) << "linked over a connection that carries nothing";
    EXPECT_EQ(relay.accepted(), 1);
    kr_.reset();
    jp_.reset();
  }
  tcp_port_ = free_udp_port(SOCK_STREAM);
  FirstConnectionSilentRelay relay(tcp_port_);
  start_behind(relay, "2000");
  ASSERT_TRUE(wait_for_service("jp/rt.Diagnostic0", 60s)) << kr_->log() << jp_->log();
  ASSERT_NO_FATAL_FAILURE(expect_echo("jp/rt.Diagnostic0", "after joining again"));
  EXPECT_GE(relay.accepted(), 2);
  EXPECT_NE(kr_->log().find("has met no one"), std::string::npos) << kr_->log();
  kr_.reset();  // before the relay: its connections end with the bridges
  jp_.reset();
}

// A listening port another process holds: bridge-jp says so and tries again (Fast DDS alone would
// only log that its acceptor could not bind, and listen nowhere), and links once the port is free.
TEST_F(PlainTcpFederation, AListeningPortInUseIsSaidAndTakenOnceFree) {
  kr_.reset();
  jp_.reset();
  ASSERT_TRUE(wait_service_gone("jp/rt.Diagnostic0", 15s));
  tcp_port_ = kr_connects_to_ = free_udp_port(SOCK_STREAM);
  const int holder = socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_addr.s_addr = htonl(INADDR_ANY);
  address.sin_port = htons(tcp_port_);
  ASSERT_EQ(bind(holder, reinterpret_cast<sockaddr*>(&address), sizeof address), 0) << std::strerror(errno);
  ASSERT_EQ(listen(holder, 1), 0);
  start_jp();
  start_kr();
  const std::string refusal = "cannot listen on port " + std::to_string(tcp_port_) + ": another process listens there";
  EXPECT_TRUE(wait_until([&] { return jp_->log().find(refusal) != std::string::npos; }, 15s)) << jp_->log();
  close(holder);
  EXPECT_TRUE(wait_for_service("jp/rt.Diagnostic0", 60s)) << jp_->log() << kr_->log();
}

// A Fast DDS discovery server over TCP: bridge-jp the server on its listening port, bridge-kr a
// client that does not listen and connects only to the server's address. Plain only (Fast DDS
// 2.9's discovery server and DDS-Security do not go together). On a loaded machine the client's
// first connection can stall (docs/sites.md, "Limits"): it joins again after
// dds.tcp.rejoin_after_ms (20 s), which the 60 s wait covers.
TEST_F(PlainTcpFederation, SpacesLinkThroughADiscoveryServerOverTcp) {
  jp_.reset();
  kr_.reset();
  ASSERT_TRUE(wait_service_gone("jp/rt.Diagnostic0", 15s));
  kr_connects_to_ = 0;
  tcp_port_ = free_udp_port(SOCK_STREAM);  // a port of its own: the first bridge-jp's may be closing still
  start_jp("  discovery: {listen: \"0.0.0.0:" + std::to_string(tcp_port_) + "\"}\n");
  start_kr("  discovery: {servers: [\"127.0.0.1:" + std::to_string(tcp_port_) + "\"]}\n");
  ASSERT_TRUE(wait_for_service("jp/rt.Diagnostic0", 60s)) << jp_->log() << kr_->log();
  ASSERT_NO_FATAL_FAILURE(expect_echo("jp/rt.Diagnostic0", "through the discovery server over TCP"));
  ASSERT_NO_FATAL_FAILURE(expect_image("jp/rt.Diagnostic0"));
}

// A peer whose name resolves only after the bridge started (between containers: the other space's
// bridge container started later). The space works without the link meanwhile, and the bridge
// joins the link once the name resolves. bridge-kr runs in a mount namespace of its own, over a
// hosts file the test writes; without the right to make one (not root), the test is skipped.
TEST_F(PlainFederation, ABridgeJoinsTheLinkOnceItsPeersNameResolves) {
  kr_.reset();
  ASSERT_TRUE(wait_service_gone("jp/rt.Diagnostic0", 15s));
  const std::string hosts = dir_ + "/hosts";
  std::filesystem::copy_file("/etc/hosts", hosts);
  const std::vector<std::string> own_hosts{
      "/usr/bin/unshare", "--mount", "--", "/bin/sh", "-c", "mount --bind \"$0\" /etc/hosts && exec \"$@\"", hosts};
  std::vector<std::string> probe = own_hosts;
  probe.push_back("true");
  const CommandResult can = run_command(probe, 10s);
  if (can.exit_code != 0) GTEST_SKIP() << "no private /etc/hosts here: " << can.err;

  start_kr("  initial_peers: [\"jp-bridge-later\"]\n", "\"room.*\"", own_hosts);
  ASSERT_TRUE(wait_until([&] { return kr_->log().find("no link to other spaces yet") != std::string::npos; }, 10s))
      << kr_->log();
  EXPECT_NE(kr_->log().find("cannot resolve jp-bridge-later"), std::string::npos) << kr_->log();
  EXPECT_FALSE(wait_for_service("jp/rt.Diagnostic0", 3s));
  ASSERT_NO_FATAL_FAILURE(expect_echo("diag", "kr works without the link"));

  std::ofstream(hosts, std::ios::app) << "127.0.0.1 jp-bridge-later\n";  // the same file: the bind mount sees it
  ASSERT_TRUE(wait_for_service("jp/rt.Diagnostic0", 20s)) << kr_->log();
  ASSERT_NO_FATAL_FAILURE(expect_echo("jp/rt.Diagnostic0", "linked once the name resolved"));
  EXPECT_NE(kr_->log().find("joined the link to other spaces"), std::string::npos) << kr_->log();
}

// The TCP sockets process `pid` listens on (from its descriptors and /proc/net/tcp{,6}).
std::set<std::string> listening_tcp(pid_t pid) {
  std::set<std::string> inodes;
  const std::string fds = "/proc/" + std::to_string(pid) + "/fd";
  for (const auto& fd : std::filesystem::directory_iterator(fds)) {
    std::error_code error;
    const std::string target = std::filesystem::read_symlink(fd.path(), error).string();
    if (!error && target.rfind("socket:[", 0) == 0) inodes.insert(target.substr(8, target.size() - 9));
  }
  std::set<std::string> listening;
  for (const char* table : {"/proc/net/tcp", "/proc/net/tcp6"}) {
    std::ifstream in(table);
    std::string line;
    std::getline(in, line);  // the header
    while (std::getline(in, line)) {
      std::istringstream fields(line);
      std::string slot, local, remote, state, queues, timer, retransmits, uid, timeout, inode;
      fields >> slot >> local >> remote >> state >> queues >> timer >> retransmits >> uid >> timeout >> inode;
      if (state == "0A" && inodes.count(inode)) listening.insert(local);  // 0A: LISTEN
    }
  }
  return listening;
}

// bridge-kr has a CAMUS server and no naming service: it starts no ORB, so nothing of it listens
// for GIOP (its link is UDP, its Planet session a client). bridge-jp, with an RT side, does.
TEST_F(PlainFederation, ABridgeWithoutANamingServiceStartsNoOrb) {
  ASSERT_TRUE(wait_for_service("jp/rt.Diagnostic0", 20s)) << kr_->log();
  EXPECT_EQ(listening_tcp(kr_->pid()), std::set<std::string>{});
  EXPECT_FALSE(listening_tcp(jp_->pid()).empty()) << "bridge-jp's ORB listens for its RTCs";
}

// The unicast addresses each participant of a domain announces (metatraffic and user data), by
// participant name, as a raw Fast DDS participant with the builtin transports discovers them.
class AnnouncedAddresses : public eprosima::fastdds::dds::DomainParticipantListener {
 public:
  explicit AnnouncedAddresses(uint32_t domain) {
    namespace fdds = eprosima::fastdds::dds;
    participant_ =
        fdds::DomainParticipantFactory::get_instance()->create_participant(domain, fdds::PARTICIPANT_QOS_DEFAULT, this);
    if (participant_ == nullptr) throw std::runtime_error("cannot join domain " + std::to_string(domain));
  }
  ~AnnouncedAddresses() override {
    participant_->set_listener(nullptr);
    eprosima::fastdds::dds::DomainParticipantFactory::get_instance()->delete_participant(participant_);
  }
  AnnouncedAddresses(const AnnouncedAddresses&) = delete;
  AnnouncedAddresses& operator=(const AnnouncedAddresses&) = delete;

  // The addresses participant `name` announces, once discovered (empty if not within `timeout`).
  std::set<std::string> of(const std::string& name, std::chrono::milliseconds timeout) {
    std::unique_lock lock(mutex_);
    changed_.wait_for(lock, timeout, [&] { return found_.count(name) != 0; });
    auto it = found_.find(name);
    return it == found_.end() ? std::set<std::string>{} : it->second;
  }

  // DomainParticipantListener
  void on_participant_discovery(eprosima::fastdds::dds::DomainParticipant*,
                                eprosima::fastrtps::rtps::ParticipantDiscoveryInfo&& info) override {
    using Status = eprosima::fastrtps::rtps::ParticipantDiscoveryInfo::DISCOVERY_STATUS;
    if (info.status != Status::DISCOVERED_PARTICIPANT) return;
    std::set<std::string> addresses;
    for (const auto* list : {&info.info.metatraffic_locators.unicast, &info.info.default_locators.unicast}) {
      for (const auto& locator : *list) addresses.insert(eprosima::fastrtps::rtps::IPLocator::ip_to_string(locator));
    }
    std::lock_guard lock(mutex_);
    found_[info.info.m_participantName.to_string()] = std::move(addresses);
    changed_.notify_all();
  }

 private:
  eprosima::fastdds::dds::DomainParticipant* participant_ = nullptr;
  std::mutex mutex_;
  std::condition_variable changed_;
  std::map<std::string, std::set<std::string>> found_;
};

// Both bridges kept to loopback (dds.interfaces: [127.0.0.1], UDP only): they link (multicast
// discovery on loopback), and each announces no address but 127.0.0.1, so no other host is told
// where to reach it. (Both, because Fast DDS 2.9 kept to loopback sends to no unicast address
// outside its list, and a participant of a host with other interfaces announces only those:
// docs/federation.md.) bridge-jp's ORB, with no --listen and omniNames on loopback, listens on
// 127.0.0.1 only too (docs/bridge.md, "What a bridge listens on").
class LoopbackFederation : public PlainFederation {
 protected:
  std::string jp_transport() const override { return "  udp_only: true\n  interfaces: [127.0.0.1]\n"; }
  std::string kr_transport() const override { return "  udp_only: true\n  interfaces: [127.0.0.1]\n"; }
};

TEST_F(LoopbackFederation, ABridgeKeptToLoopbackLinksAndAnnouncesOnlyLoopback) {
  ASSERT_TRUE(wait_for_service("jp/rt.Diagnostic0", 20s)) << jp_->log() << kr_->log();
  ASSERT_NO_FATAL_FAILURE(expect_echo("jp/rt.Diagnostic0", "over loopback only"));
  EXPECT_NE(jp_->log().find("dds: the link's UDP transport uses only the interfaces 127.0.0.1\n"), std::string::npos)
      << jp_->log();

  AnnouncedAddresses announced(static_cast<uint32_t>(domain_));
  EXPECT_EQ(announced.of("urs-bridge/jp/bridge-jp", 15s), std::set<std::string>{"127.0.0.1"});
  EXPECT_EQ(announced.of("urs-bridge/kr/bridge-kr", 15s), std::set<std::string>{"127.0.0.1"});
  // Its ORB's listening sockets: "0100007F:PORT" is 127.0.0.1 in /proc/net/tcp.
  const std::set<std::string> listening = listening_tcp(jp_->pid());
  ASSERT_FALSE(listening.empty());
  for (const auto& local : listening) EXPECT_EQ(local.substr(0, 9), "0100007F:") << local;
}

// Calls authorized per service on a secured link: kr's CAMUS server admits named credentials
// (the fixture's own "space-admin", "operator-ann" and "visitor"); jp's bridge exports every
// service, lets kr's space-admin and operators call rt.Diagnostic* and nobody rt.Secret*, and
// writes each call it serves to its audit log, rotated at 2 KiB.
class AuthorizedFederation : public Federation {
 protected:
  void SetUp() override {
    credentials_ = {{"operator-ann", "client"}, {"visitor", "client"}};
    Federation::SetUp();
  }
  bool secured() const override { return true; }
  std::string jp_export() override {
    std::filesystem::create_directories(dir_ + "/audit");
    return "  export:\n"
           "    callers: {\"rt.Secret*\": [], \"rt.Diagnostic*\": [\"kr/operator-*\", kr/space-admin]}\n" +
           std::string(trust_declared_space() ? "    trust_declared_space: true\n" : "") + "  audit: {file: \"" +
           audit_file() + "\", max_bytes: 2048, files: 2}\n";
  }
  std::string audit_file() const { return dir_ + "/audit/calls.jsonl"; }
  virtual bool trust_declared_space() const { return false; }

  // The audit log's lines, the rotated files' first (oldest first).
  std::vector<std::string> audited() const {
    std::vector<std::string> lines;
    for (const char* name : {"calls.2.jsonl", "calls.1.jsonl", "calls.jsonl"}) {
      std::ifstream in(dir_ + "/audit/" + name);
      for (std::string line; std::getline(in, line);) lines.push_back(line);
    }
    return lines;
  }
  // kr's space-admin calls jp's rt.Diagnostic0 (granted: it answers `text`) and rt.Secret0
  // (refused with the reason).
  void expect_granted_and_refused(const std::string& text) {
    ASSERT_TRUE(wait_for_service("jp/rt.Diagnostic0", 20s)) << kr_->log() << jp_->log();
    ASSERT_TRUE(wait_for_service("jp/rt.Secret0", 20s)) << kr_->log() << jp_->log();
    ASSERT_NO_FATAL_FAILURE(expect_echo("jp/rt.Diagnostic0", text));
    URS::Diagnostic_echo_Request echo;
    echo.set_text("not granted");
    const Observed refused = call("jp/rt.Secret0", "echo", echo);
    EXPECT_EQ(refused.status, planet::PERMISSION_DENIED) << refused.message;
    EXPECT_NE(refused.message.find("kr/space-admin may not call jp/rt.Secret0"), std::string::npos) << refused.message;
  }
  // The audited lines holding every one of `parts`.
  std::size_t audited_with(const std::vector<std::string>& parts) const {
    std::size_t count = 0;
    for (const auto& line : audited()) {
      bool all = true;
      for (const auto& part : parts) all = all && line.find(part) != std::string::npos;
      count += all ? 1 : 0;
    }
    return count;
  }
};

TEST_F(AuthorizedFederation, AGrantedSpaceIsServedOthersAreRefusedWithTheReasonAndEveryCallIsAudited) {
  ASSERT_NO_FATAL_FAILURE(expect_granted_and_refused("granted"));

  // Each line is written before the reply leaves: both are there now.
  EXPECT_EQ(
      audited_with({"\"caller_space\":\"kr\",\"caller\":\"space-admin\",\"space_verified\":true",
                    "\"service\":\"rt.Diagnostic0\",\"operation\":\"echo\"", "\"status\":\"OK\"", "\"duration_us\":"}),
      1u)
      << ::testing::PrintToString(audited());
  EXPECT_EQ(audited_with({"\"caller_space\":\"kr\",\"caller\":\"space-admin\"", "\"service\":\"rt.Secret0\"",
                          "\"status\":\"PERMISSION_DENIED\",\"reason\":\"kr/space-admin may not call jp/rt.Secret0\""}),
            1u)
      << ::testing::PrintToString(audited());
  for (const auto& line : audited()) EXPECT_EQ(line.find("granted"), std::string::npos) << "a payload: " << line;

  // The log rotates at 2 KiB and keeps two rotated files besides the current one.
  for (int i = 0; i < 40 && !std::filesystem::exists(dir_ + "/audit/calls.2.jsonl"); ++i) {
    ASSERT_NO_FATAL_FAILURE(expect_echo("jp/rt.Diagnostic0", "again"));
  }
  ASSERT_TRUE(std::filesystem::exists(dir_ + "/audit/calls.2.jsonl"));
  ASSERT_NO_FATAL_FAILURE(expect_echo("jp/rt.Diagnostic0", "once more"));
  for (const char* name : {"calls.jsonl", "calls.1.jsonl", "calls.2.jsonl"}) {
    EXPECT_LE(std::filesystem::file_size(dir_ + "/audit/" + name), 2048u) << name;
  }
  EXPECT_FALSE(std::filesystem::exists(dir_ + "/audit/calls.3.jsonl"));
}

// Inside kr, the callers are told apart by the names kr's CAMUS server authenticated: kr's
// bridge passes the name on, jp's bridge takes it from kr's proven participant and judges it by
// "kr/operator-*": operator-ann is served, visitor refused with the reason, both audited by name.
TEST_F(AuthorizedFederation, ACallerInsideASpaceIsJudgedByTheNameItsServerAuthenticated) {
  ASSERT_TRUE(wait_for_service("jp/rt.Diagnostic0", 20s)) << kr_->log() << jp_->log();
  auto ann = connect_client("ann", "operator-ann");
  auto visitor = connect_client("visitor", "visitor");
  ASSERT_TRUE(ann->wait_connected(5s)) << ann->last_error();
  ASSERT_TRUE(visitor->wait_connected(5s)) << visitor->last_error();
  EXPECT_EQ(ann->welcome().identity(), "operator-ann");

  URS::Diagnostic_echo_Request echo;
  echo.set_text("from ann");
  const auto served = ann->call("jp/rt.Diagnostic0", "echo", echo.SerializeAsString(), 5s);
  ASSERT_EQ(served.status, planet::OK) << served.message;
  URS::Diagnostic_echo_Reply reply;
  ASSERT_TRUE(reply.ParseFromString(served.payload));
  EXPECT_EQ(reply.result(), "from ann");

  echo.set_text("from visitor");
  const auto refused = visitor->call("jp/rt.Diagnostic0", "echo", echo.SerializeAsString(), 5s);
  EXPECT_EQ(refused.status, planet::PERMISSION_DENIED) << refused.message;
  EXPECT_NE(refused.message.find("kr/visitor may not call jp/rt.Diagnostic0"), std::string::npos) << refused.message;

  EXPECT_EQ(audited_with({"\"caller_space\":\"kr\",\"caller\":\"operator-ann\",\"space_verified\":true",
                          "\"service\":\"rt.Diagnostic0\",\"operation\":\"echo\"", "\"status\":\"OK\""}),
            1u)
      << ::testing::PrintToString(audited());
  EXPECT_EQ(audited_with({"\"caller_space\":\"kr\",\"caller\":\"visitor\",\"space_verified\":true",
                          "\"status\":\"PERMISSION_DENIED\",\"reason\":\"kr/visitor may not call jp/rt.Diagnostic0\""}),
            1u)
      << ::testing::PrintToString(audited());
}

// Member "spy", whose certificate names space spy and whose permissions let it call jp, is
// served as spy, whatever its requests declare: refused with spy's reason (no rule lists spy),
// its reply sent to spy, and audited as spy, verified. The name inside its space it gives is
// spy's to give: judged as spy's, never kr's.
TEST_F(AuthorizedFederation, AMemberIsJudgedByTheSpaceItsCertificateNamesNotTheOneItDeclares) {
  ASSERT_TRUE(wait_for_service("jp/rt.Diagnostic0", 20s)) << kr_->log() << jp_->log();
  federation::DdsLink spy(
      spy_options(), [] {}, [](call::Request, call::Responder) {});
  // Authenticated with jp's bridge (its catalog reaches spy) before the first call: a call waits
  // for a match only so long.
  ASSERT_TRUE(wait_until(
      [&] {
        const auto entries = spy.catalog();
        return std::any_of(entries.begin(), entries.end(), [](const auto& entry) { return entry.space == "jp"; });
      },
      20s));

  URS::Diagnostic_echo_Request echo;
  echo.set_text("from spy");
  const call::Reply honest = spy.call("jp", "rt.Diagnostic0", "echo", echo.SerializeAsString(), 10s);
  EXPECT_EQ(honest.status, call::Status::PERMISSION_DENIED) << honest.message;
  EXPECT_EQ(honest.message, "space spy may not call jp/rt.Diagnostic0");
  // A name inside its space that is no name (here a bridge's) is refused before any rule.
  const call::Reply misnamed = spy.call("jp", "rt.Diagnostic0", "echo", echo.SerializeAsString(), 10s, "dds:kr");
  EXPECT_EQ(misnamed.status, call::Status::BAD_ARGUMENTS) << misnamed.message;
  EXPECT_EQ(misnamed.message,
            "the caller's name (CallRequest.caller_name) 'dds:kr' begins with 'dds:' (the bridges' "
            "own names)");

  // The same participant writes a request of its own declaring space kr, which may call it.
  namespace fdds = eprosima::fastdds::dds;
  fdds::DomainParticipant* participant = spy.participant();
  auto* topic = dynamic_cast<fdds::Topic*>(participant->lookup_topicdescription("urs/rpc/jp/request"));
  ASSERT_NE(topic, nullptr);  // made by the call above
  fdds::Publisher* publisher = participant->create_publisher(fdds::PUBLISHER_QOS_DEFAULT);
  fdds::DataWriterQos qos = fdds::DATAWRITER_QOS_DEFAULT;
  qos.reliability().kind = fdds::RELIABLE_RELIABILITY_QOS;
  qos.durability().kind = fdds::TRANSIENT_LOCAL_DURABILITY_QOS;
  qos.history().kind = fdds::KEEP_LAST_HISTORY_QOS;
  qos.history().depth = 1;
  fdds::DataWriter* writer = publisher->create_datawriter(topic, qos);
  ASSERT_NE(writer, nullptr);
  dds::CallRequest forged;
  forged.request_id("kr/bridge-kr/forged/1");
  forged.caller_space("kr");
  forged.service("rt.Diagnostic0");
  forged.operation("blob");
  forged.deadline_ms(10000);
  forged.no_reply(false);
  forged.caller_name("operator-ann");
  ASSERT_TRUE(writer->write(&forged));

  EXPECT_TRUE(wait_until(
      [&] {
        return audited_with({"\"caller_space\":\"spy\",\"caller\":\"operator-ann\",\"space_verified\":true",
                             "\"operation\":\"blob\"",
                             "\"reason\":\"spy/operator-ann may not call jp/rt.Diagnostic0\""}) == 1;
      },
      10s))
      << ::testing::PrintToString(audited()) << jp_->log();
  EXPECT_EQ(audited_with({"\"caller_space\":\"kr\"", "\"operation\":\"blob\""}), 0u);
  EXPECT_NE(jp_->log().find("certificate is space spy declares space kr"), std::string::npos) << jp_->log();
  publisher->delete_datawriter(writer);
  participant->delete_publisher(publisher);
}

// The same rules on a plain link, where nothing proves a caller's space: calls are refused unless
// jp's operator trusts the declared space, and then judged by it, audited as not verified.
class DeclaredSpaceFederation : public AuthorizedFederation {
 protected:
  bool secured() const override { return false; }
};
class TrustingDeclaredSpaceFederation : public DeclaredSpaceFederation {
 protected:
  bool trust_declared_space() const override { return true; }
};

TEST_F(DeclaredSpaceFederation, ADeclaredSpaceIsRefusedUnlessTrusted) {
  ASSERT_TRUE(wait_for_service("jp/rt.Diagnostic0", 20s)) << kr_->log() << jp_->log();
  URS::Diagnostic_echo_Request echo;
  echo.set_text("declared");
  const Observed refused = call("jp/rt.Diagnostic0", "echo", echo);
  EXPECT_EQ(refused.status, planet::PERMISSION_DENIED) << refused.message;
  EXPECT_NE(refused.message.find("kr/space-admin may not call jp/rt.Diagnostic0: its space is only declared"),
            std::string::npos)
      << refused.message;
  EXPECT_EQ(audited_with({"\"caller_space\":\"kr\",\"caller\":\"space-admin\",\"space_verified\":false",
                          "\"status\":\"PERMISSION_DENIED\""}),
            1u)
      << ::testing::PrintToString(audited());
}

TEST_F(TrustingDeclaredSpaceFederation, ADeclaredSpaceIsJudgedByWhatItDeclaresWhereTrusted) {
  ASSERT_NO_FATAL_FAILURE(expect_granted_and_refused("declared and trusted"));
  EXPECT_EQ(audited_with({"\"caller_space\":\"kr\",\"caller\":\"space-admin\",\"space_verified\":false",
                          "\"service\":\"rt.Diagnostic0\"", "\"status\":\"OK\""}),
            1u)
      << ::testing::PrintToString(audited());
}

// What a third space sees of the others' state over DDS: a participant of the link (a member "obs"
// on a secured link).
struct StateObserver {
  StateObserver(uint32_t domain, std::chrono::milliseconds lease, federation::DdsSecurity security) {
    federation::DdsOptions options;
    options.domain = domain;
    options.space = "obs";
    options.bridge = "observer";
    options.lease = lease;
    options.udp_only = true;
    options.security = std::move(security);
    link = std::make_unique<federation::DdsLink>(
        options, [] {}, [](call::Request, call::Responder) {});
    federation::StateHandlers handlers;
    handlers.component = [this](const federation::ComponentState& c, bool alive) {
      std::lock_guard lock(mutex);
      if (alive) {
        components[c.space + "/" + c.name] = c;
      } else {
        components.erase(c.space + "/" + c.name);
      }
    };
    handlers.context = [this](const federation::ContextState& e, bool alive) {
      std::lock_guard lock(mutex);
      if (alive) {
        context[e.space + "/" + e.key] = e.value_json;
      } else {
        context.erase(e.space + "/" + e.key);
      }
    };
    handlers.event = [this](const federation::SpaceEvent& e) {
      std::lock_guard lock(mutex);
      events.push_back(e);
    };
    state = std::make_unique<federation::StateLink>(*link, handlers, std::nullopt);
  }
  template <class F>
  auto with(F f) {
    std::lock_guard lock(mutex);
    return f();
  }

  std::mutex mutex;
  std::map<std::string, federation::ComponentState> components;
  std::map<std::string, std::string> context;
  std::vector<federation::SpaceEvent> events;
  std::unique_ptr<federation::DdsLink> link;
  std::unique_ptr<federation::StateLink> state;  // last: destroyed first
};

TEST_P(Federation, SpacesShareStateOverDds) {
  StateObserver observer(static_cast<uint32_t>(domain_), kLease, observer_security());
  const std::string diag = "jphost.host_cxt/Diagnostic0.rtc";

  // jp's RTC lifecycle states reach kr's context, and follow the component's transitions.
  ASSERT_TRUE(wait_until([&] { return !context_field("jp/component/" + diag, "state").empty(); }, 20s)) << jp_->log();
  EXPECT_EQ(context_field("jp/component/" + diag, "type_name"), "Diagnostic");
  EXPECT_EQ(context_field("jp/component/" + diag, "host"), "jphost.host_cxt");
  auto rtc = resolve<RTC::RTObject>(diag);
  RTC::ExecutionContextList_var contexts = rtc->get_owned_contexts();
  ASSERT_GT(contexts->length(), 0u);
  ASSERT_EQ(contexts[0]->activate_component(rtc), RTC::RTC_OK);
  EXPECT_TRUE(wait_until([&] { return context_field("jp/component/" + diag, "state") == "Active"; }, 10s));
  ASSERT_EQ(contexts[0]->deactivate_component(rtc), RTC::RTC_OK);
  EXPECT_TRUE(wait_until([&] { return context_field("jp/component/" + diag, "state") == "Inactive"; }, 10s));
  // The bridge's own RTC stands for nothing of jp's own: not shared.
  EXPECT_FALSE(context("jp/component/jphost.host_cxt/Bridge0.rtc"));

  // A robot of jp, on jp's own devices domain: its pose reaches kr's context.
  world::World devices(devices_domain(), "federation-test-robot");
  world::PoseSample pose;
  pose.robot = "robot1";
  pose.x = 1.25;
  pose.y = 3.5;
  pose.theta = 0.5;
  pose.stamp = std::chrono::system_clock::now();
  ASSERT_TRUE(wait_until(
      [&] {
        devices.publish(world::Channel::ground_truth, pose);
        return context_field("jp/pose/robot1", "x") == std::to_string(1.25);
      },
      20s))
      << jp_->log() << kr_->log();
  EXPECT_EQ(context_field("jp/pose/robot1", "y"), std::to_string(3.5));
  // Its stamp to the nanosecond: a string, which a JSON number (a double) would round.
  EXPECT_EQ(
      context_field("jp/pose/robot1", "stamp_unix_ns"),
      std::to_string(std::chrono::duration_cast<std::chrono::nanoseconds>(pose.stamp.time_since_epoch()).count()));

  // kr's agents and the context entries it allows reach the observer; those it denies do not.
  EXPECT_TRUE(
      wait_until([&] { return observer.with([&] { return observer.components.count("kr/diag") == 1; }); }, 20s));
  EXPECT_EQ(observer.with([&] { return observer.components["kr/diag"].kind; }), "agent");
  EXPECT_EQ(observer.with([&] { return observer.components["kr/diag"].state; }), "Available");
  EXPECT_TRUE(
      wait_until([&] { return observer.with([&] { return observer.components.count("jp/" + diag) == 1; }); }, 10s));
  ASSERT_EQ(urs({"context", "set", "room.temperature", "21.5"}).exit_code, 0);
  ASSERT_EQ(urs({"context", "set", "secret.code", "\"1234\""}).exit_code, 0);
  EXPECT_TRUE(wait_until(
      [&] { return observer.with([&] { return observer.context.count("kr/room.temperature") == 1; }); }, 10s));
  EXPECT_EQ(observer.with([&] { return observer.context["kr/room.temperature"]; }), "21.5");
  ASSERT_EQ(urs({"context", "rm", "room.temperature"}).exit_code, 0);
  EXPECT_TRUE(wait_until([&] { return observer.with([&] { return observer.context.empty(); }); }, 10s));
  EXPECT_EQ(observer.with([&] { return observer.context.count("kr/secret.code"); }), 0u);

  // kr's events on the shared topics reach the observer, every one and in order.
  constexpr int kEvents = 300;
  for (int i = 0; i < kEvents; ++i) {
    google::protobuf::Value value;
    value.set_number_value(i);
    ASSERT_TRUE(planet_->publish("alarm/fire", value.SerializeAsString(), value.GetTypeName()).ok());
  }
  ASSERT_TRUE(planet_->publish("other/topic", "x", "none").ok());
  EXPECT_TRUE(wait_until([&] { return observer.with([&] { return observer.events.size() >= kEvents; }); }, 20s))
      << observer.with([&] { return observer.events.size(); });
  observer.with([&] {
    ASSERT_EQ(observer.events.size(), static_cast<std::size_t>(kEvents));
    for (int i = 0; i < kEvents; ++i) {
      google::protobuf::Value value;
      ASSERT_TRUE(value.ParseFromString(observer.events[i].payload));
      EXPECT_EQ(value.number_value(), i);
      EXPECT_EQ(observer.events[i].topic, "alarm/fire");
      EXPECT_EQ(observer.events[i].space, "kr");
      if (i > 0) {
        EXPECT_GT(observer.events[i].seq, observer.events[i - 1].seq);
      }
    }
  });

  // kr's CAMUS server dies and comes back on its port: what jp shares keeps arriving.
  restart_server();
  ASSERT_TRUE(planet_->wait_connected(10s));
  pose.x = 2.75;
  ASSERT_TRUE(wait_until(
      [&] {
        devices.publish(world::Channel::ground_truth, pose);
        return context_field("jp/pose/robot1", "x") == std::to_string(2.75);
      },
      20s))
      << kr_->log();

  // A lost bridge's state ends with it, in kr's context and at the observer, and comes back.
  jp_->kill9();
  EXPECT_TRUE(wait_until([&] { return !context("jp/component/" + diag); }, kLease * 6));
  EXPECT_TRUE(wait_until([&] { return observer.with([&] { return observer.components.count("jp/" + diag) == 0; }); },
                         kLease * 6));
  start_jp();  // a new participant: on a secured link, a new handshake too
  EXPECT_TRUE(wait_until([&] { return context_field("jp/component/" + diag, "state") == "Inactive"; }, kRelink));
}

// A participant of the link of the test's own: a member on a secured link (with the files of
// `security`), else plain.
eprosima::fastdds::dds::DomainParticipant* join_link(uint32_t domain, const federation::DdsSecurity& security) {
  namespace fdds = eprosima::fastdds::dds;
  auto* factory = fdds::DomainParticipantFactory::get_instance();
  fdds::DomainParticipantQos participant_qos = factory->get_default_participant_qos();
  if (security.enabled()) {
    for (const auto& [name, value] : federation::dds_security_properties(security)) {
      participant_qos.properties().properties().emplace_back(name, value);
    }
  }
  return factory->create_participant(domain, participant_qos);
}

// Every sample written on urs/state/context, as a plain DDS reader of the link sees it (keep-all:
// tombstones included, which StateLink's own reader folds away); a member on a secured link.
class ContextTap {
 public:
  ContextTap(uint32_t domain, const federation::DdsSecurity& security) {
    namespace fdds = eprosima::fastdds::dds;
    participant_ = join_link(domain, security);
    type_.register_type(participant_);
    topic_ = participant_->create_topic("urs/state/context", type_.get_type_name(), fdds::TOPIC_QOS_DEFAULT);
    fdds::DataReaderQos qos = fdds::DATAREADER_QOS_DEFAULT;
    qos.reliability().kind = fdds::RELIABLE_RELIABILITY_QOS;
    qos.durability().kind = fdds::TRANSIENT_LOCAL_DURABILITY_QOS;
    qos.history().kind = fdds::KEEP_ALL_HISTORY_QOS;
    // On a secured link the spaces share their state in their own partitions: read them all.
    fdds::SubscriberQos subscriber_qos = fdds::SUBSCRIBER_QOS_DEFAULT;
    if (security.enabled()) subscriber_qos.partition().push_back("*");
    reader_ = participant_->create_subscriber(subscriber_qos)->create_datareader(topic_, qos);
  }
  ~ContextTap() {
    participant_->delete_contained_entities();
    eprosima::fastdds::dds::DomainParticipantFactory::get_instance()->delete_participant(participant_);
  }
  // Every (space, key, value_json) received so far.
  const std::vector<urs::dds::ContextEntry>& samples() {
    urs::dds::ContextEntry sample;
    eprosima::fastdds::dds::SampleInfo info;
    while (reader_->take_next_sample(&sample, &info) == ReturnCode_t::RETCODE_OK) {
      if (info.valid_data) samples_.push_back(sample);
    }
    return samples_;
  }
  bool has(const std::string& space, const std::string& key, bool removed) {
    for (const auto& s : samples()) {
      if (s.space() == space && s.key() == key && s.value_json().empty() == removed) return true;
    }
    return false;
  }

 private:
  eprosima::fastdds::dds::DomainParticipant* participant_ = nullptr;
  eprosima::fastdds::dds::TypeSupport type_{new urs::dds::ContextEntryPubSubType()};
  eprosima::fastdds::dds::Topic* topic_ = nullptr;
  eprosima::fastdds::dds::DataReader* reader_ = nullptr;
  std::vector<urs::dds::ContextEntry> samples_;
};

// kr shares all of its context, which also holds what it imported from jp ("jp/..." keys, source
// "dds:jp"): neither those entries nor their removals (when jp's bridge is lost) are written on the
// link as kr's, while kr's own keys and their removals are.
TEST_P(Federation, ImportedStateIsNeverSharedAgainNorItsRemoval) {
  kr_.reset();
  start_kr("", "\"*\"");
  ContextTap tap(static_cast<uint32_t>(domain_), observer_security());
  const std::string imported = "jp/component/jphost.host_cxt/Diagnostic0.rtc";
  ASSERT_TRUE(wait_until([&] { return context(imported).has_value(); }, 20s)) << kr_->log();
  ASSERT_EQ(urs({"context", "set", "room.before", "1"}).exit_code, 0);
  ASSERT_TRUE(wait_until([&] { return tap.has("kr", "room.before", false); }, 10s));

  jp_->kill9();  // kr removes what it imported from jp
  ASSERT_TRUE(wait_until([&] { return !context(imported).has_value(); }, kLease * 6)) << kr_->log();
  // kr's exporter shares in order: once the removal of a key set after jp's entries went away
  // is seen, anything it wrote about those entries has been seen too.
  ASSERT_EQ(urs({"context", "set", "room.after", "2"}).exit_code, 0);
  ASSERT_EQ(urs({"context", "rm", "room.after"}).exit_code, 0);
  ASSERT_TRUE(wait_until([&] { return tap.has("kr", "room.after", true); }, 10s));
  for (const auto& sample : tap.samples()) {
    EXPECT_NE(sample.key().rfind("jp/", 0), 0u)
        << "kr shared " << sample.key() << " (value '" << sample.value_json() << "') as its own";
  }
}

// kr shares every event of its space ("#"), the registry's included: the registry's events of a
// service of kr's own leave kr; those of the services kr imports from jp (registry/jp/...) do
// not, neither when the services arrive nor when they leave with jp's bridge.
TEST_P(Federation, TheRegistrysEventsOfImportedServicesAreNotSharedAgain) {
  StateObserver observer(static_cast<uint32_t>(domain_), kLease, observer_security());
  kr_.reset();
  kr_ = launch_bridge("bridge-kr",
                      "name: bridge-kr\n" + dds("", kr_transport()) +
                          "  import: {as_rtc: \"\"}\n"
                          "  state: {events: [\"#\"]}\n",
                      {"--server", server_address_});
  ASSERT_TRUE(wait_for_service("jp/rt.Diagnostic0", 20s)) << kr_->log();
  const auto shared = [&](const std::string& topic) {
    return observer.with([&] {
      return std::any_of(observer.events.begin(), observer.events.end(),
                         [&](const auto& e) { return e.space == "kr" && e.topic == topic; });
    });
  };

  // kr's events reach the observer once its writer has matched the observer's reader.
  ASSERT_TRUE(wait_until(
      [&] {
        EXPECT_TRUE(planet_->publish("alarm/before", "x", "none").ok());
        return wait_until([&] { return shared("alarm/before"); }, 200ms);
      },
      20s))
      << kr_->log();

  planet::ClientOptions options;
  options.port = static_cast<uint16_t>(std::stoi(server_address_.substr(server_address_.rfind(':') + 1)));
  options.peer_name = "own-sam";
  options.role = planet::SAM;
  planet::Client own(options);
  own.start();
  camus::RegisterRequest registration;
  registration.mutable_service()->set_name("own.probe");
  registration.mutable_service()->set_interface("URS.Diagnostic");
  registration.set_descriptor_set(schema::descriptor_set_for(*URS::Diagnostic_echo_Request::descriptor()->file()));
  own.register_service(registration);
  EXPECT_TRUE(wait_until([&] { return shared("registry/own.probe"); }, 20s)) << kr_->log();

  jp_->kill9();  // kr's imports of jp leave its registry
  ASSERT_TRUE(wait_service_gone("jp/rt.Diagnostic0", kHold + kLease * 6)) << kr_->log();
  // kr shares its events in order: once this one is seen, the registry's events before it were.
  ASSERT_TRUE(planet_->publish("alarm/after", "x", "none").ok());
  ASSERT_TRUE(wait_until([&] { return shared("alarm/after"); }, 10s)) << kr_->log();
  observer.with([&] {
    for (const auto& e : observer.events) {
      EXPECT_NE(e.topic.rfind("registry/jp/", 0), 0u) << "kr shared " << e.topic << " as its own";
    }
  });
}

// The catalog names each service's IDL repository ID, whichever middleware it comes from: kr's
// diag, a CAMUS agent whose description kr's bridge has from the registry, as jp's rt.Diagnostic0,
// an RTC's provided port.
TEST_P(Federation, TheCatalogNamesEachServicesRepositoryId) {
  StateObserver observer(static_cast<uint32_t>(domain_), kLease, observer_security());
  std::map<std::string, std::string> ids;
  ASSERT_TRUE(wait_until(
      [&] {
        for (const auto& entry : observer.link->catalog()) ids[entry.space + "/" + entry.name] = entry.repository_id;
        return ids.count("kr/diag") == 1 && ids.count("jp/rt.Diagnostic0") == 1;
      },
      20s))
      << kr_->log() << jp_->log();
  EXPECT_EQ(ids["kr/diag"], "IDL:URS/Diagnostic:1.0");
  EXPECT_EQ(ids["jp/rt.Diagnostic0"], "IDL:URS/Diagnostic:1.0");
}

// How many times `part` occurs in `text`.
std::size_t count_of(const std::string& text, const std::string& part) {
  std::size_t count = 0;
  for (auto at = text.find(part); at != std::string::npos; at = text.find(part, at + 1)) ++count;
  return count;
}

// A participant of the link writing samples of its own, in the link's keyed-state QoS, on topics
// the link made: a forger's raw writers. Kept alive by its link, as the link's own writers. On a
// secured link they write in the partition of the link's space, the only one DDS lets it write.
class RawKeyedWriters {
 public:
  RawKeyedWriters(federation::DdsLink& link, std::chrono::milliseconds lease) : link_(link) {
    namespace fdds = eprosima::fastdds::dds;
    fdds::PublisherQos publisher_qos = fdds::PUBLISHER_QOS_DEFAULT;
    if (link.options().security.enabled()) publisher_qos.partition().push_back(link.options().space.c_str());
    publisher_ = link.participant()->create_publisher(publisher_qos);
    qos_ = fdds::DATAWRITER_QOS_DEFAULT;
    qos_.reliability().kind = fdds::RELIABLE_RELIABILITY_QOS;
    qos_.durability().kind = fdds::TRANSIENT_LOCAL_DURABILITY_QOS;
    qos_.history().kind = fdds::KEEP_LAST_HISTORY_QOS;
    qos_.history().depth = 1;
    qos_.liveliness().kind = fdds::MANUAL_BY_TOPIC_LIVELINESS_QOS;
    qos_.liveliness().lease_duration = eprosima::fastrtps::Duration_t(static_cast<double>(lease.count()) / 1000.0);
  }
  ~RawKeyedWriters() {
    for (auto* writer : writers_) {
      link_.let_go(writer);
      publisher_->delete_datawriter(writer);
    }
    link_.participant()->delete_publisher(publisher_);
  }
  // Writes `sample` on `topic` (which the link made), with a writer of its own for each topic.
  template <class Sample>
  bool write(const std::string& topic, Sample sample) {
    namespace fdds = eprosima::fastdds::dds;
    auto*& writer = by_topic_[topic];
    if (writer == nullptr) {
      auto* made = dynamic_cast<fdds::Topic*>(link_.participant()->lookup_topicdescription(topic));
      if (made == nullptr) return false;
      writer = publisher_->create_datawriter(made, qos_);
      if (writer == nullptr) return false;
      writers_.push_back(writer);
      link_.keep_alive(writer);
    }
    return writer->write(&sample);
  }

 private:
  federation::DdsLink& link_;
  eprosima::fastdds::dds::Publisher* publisher_ = nullptr;
  eprosima::fastdds::dds::DataWriterQos qos_;
  std::map<std::string, eprosima::fastdds::dds::DataWriter*> by_topic_;
  std::vector<eprosima::fastdds::dds::DataWriter*> writers_;
};

// Each space speaks only for itself. Member "spy" (space spy: its certificate's on a secured link)
// writes, as space jp, a catalog entry (with kr's own description of diag, so that it could be
// served), a component state and a context entry. On a secured link kr's bridge takes none of them
// and logs who tried, while jp's own keep arriving; on a plain link, where nothing proves a
// writer's space, they are taken as jp's.
TEST_P(Federation, AMemberSpeaksOnlyForTheSpaceItsCertificateNames) {
  ASSERT_TRUE(wait_for_service("jp/rt.Diagnostic0", 20s)) << kr_->log() << jp_->log();
  const std::string diag = "jp/component/jphost.host_cxt/Diagnostic0.rtc";
  ASSERT_TRUE(wait_until([&] { return !context_field(diag, "state").empty(); }, 20s)) << jp_->log();

  federation::DdsLink spy(
      spy_options(), [] {}, [](call::Request, call::Responder) {});
  federation::StateLink spy_state(spy, {}, std::nullopt);  // makes the state topics on spy's participant
  federation::ServiceEntry described;                      // kr's diag as spy reads it: its description is kr's
  ASSERT_TRUE(wait_until(
      [&] {
        for (const auto& entry : spy.catalog()) {
          if (entry.space == "kr" && entry.name == "diag") described = entry;
        }
        return !described.descriptor_set.empty();
      },
      20s));

  RawKeyedWriters forger(spy, kLease);
  dds::InterfaceDescription description;
  description.digest(federation::description_digest(described.descriptor_set));
  description.descriptor_set(std::vector<uint8_t>(described.descriptor_set.begin(), described.descriptor_set.end()));
  ASSERT_TRUE(forger.write("urs/interface", description));
  dds::ServiceEntry entry;
  entry.space("jp");
  entry.name("rt.Forged0");
  entry.interface_name(described.interface_name);
  entry.repository_id(described.repository_id);
  entry.origin("camus");
  entry.bridge("bridge-jp");
  entry.interface_digest(description.digest());
  ASSERT_TRUE(forger.write("urs/catalog", entry));
  dds::ComponentState component;
  component.space("jp");
  component.name("jphost.host_cxt/Forged0.rtc");
  component.kind("rtc");
  component.state("Active");
  component.type_name("Diagnostic");
  component.host("jphost.host_cxt");
  ASSERT_TRUE(forger.write("urs/state/component", component));
  dds::ContextEntry context_entry;
  context_entry.space("jp");
  context_entry.key("room.door");
  context_entry.value_json("\"open\"");
  context_entry.source("forged");
  context_entry.version(1);
  ASSERT_TRUE(forger.write("urs/state/context", context_entry));

  const std::string forged_component = "jp/component/jphost.host_cxt/Forged0.rtc";
  if (!secured()) {
    EXPECT_TRUE(wait_for_service("jp/rt.Forged0", 20s)) << kr_->log();
    EXPECT_TRUE(wait_until([&] { return context_field(forged_component, "state") == "Active"; }, 20s)) << kr_->log();
    EXPECT_TRUE(wait_until([&] { return context("jp/room.door").has_value(); }, 20s)) << kr_->log();
    return;
  }
  // Each refusal is logged as kr's bridge reads the sample, before it would have imported it.
  for (const char* refused :
       {"a member proven as spy announced space jp's catalog entry jp/rt.Forged0: ignored",
        "a member proven as spy announced space jp's component state jp/jphost.host_cxt/Forged0.rtc: ignored",
        "a member proven as spy announced space jp's context entry jp/room.door: ignored"}) {
    EXPECT_TRUE(wait_until([&] { return kr_->log().find(refused) != std::string::npos; }, 20s)) << refused << "\n"
                                                                                                << kr_->log();
  }
  EXPECT_TRUE(listed("jp/rt.Forged0").empty());
  EXPECT_FALSE(context(forged_component));
  EXPECT_FALSE(context("jp/room.door"));
  // jp's own still arrive, and spy speaks for itself: its entry is taken as spy's.
  EXPECT_FALSE(listed("jp/rt.Diagnostic0").empty());
  EXPECT_FALSE(context_field(diag, "state").empty());
  entry.space("spy");
  entry.name("probe");
  ASSERT_TRUE(forger.write("urs/catalog", entry));
  EXPECT_TRUE(wait_for_service("spy/probe", 20s)) << kr_->log();
  // Each refusal once, however often the catalog and state are read.
  EXPECT_EQ(count_of(kr_->log(), "announced space jp's catalog entry jp/rt.Forged0"), 1u) << kr_->log();
}

// What tests/integration/bridge/dynamic_reader printed: the types announced (as IDL, by type name)
// and the samples (as JSON) of each topic.
struct DynamicReading {
  explicit DynamicReading(const std::string& log) {
    std::istringstream lines(log);
    for (std::string line; std::getline(lines, line);) {
      if (line.rfind("type ", 0) == 0) {
        const auto idl = line.find(" struct ");
        if (idl == std::string::npos) continue;
        const std::string declaration = line.substr(idl + 1);
        types[declaration.substr(7, declaration.find(' ', 7) - 7)] = declaration;
      } else if (line.rfind("{", 0) == 0) {
        gp::Struct sample;
        if (!gp::util::JsonStringToMessage(line, &sample).ok()) continue;
        const std::string topic = sample.fields().at("topic").string_value();
        samples[topic].push_back(sample);
      }
    }
  }
  // The samples of `topic` whose `field` is `value`.
  std::vector<gp::Struct> with(const std::string& topic, const std::string& field, const std::string& value) const {
    std::vector<gp::Struct> found;
    auto it = samples.find(topic);
    if (it == samples.end()) return found;
    for (const auto& sample : it->second) {
      const auto& fields = sample.fields().at("value").struct_value().fields();
      auto f = fields.find(field);
      if (f != fields.end() && f->second.string_value() == value) found.push_back(sample);
    }
    return found;
  }
  static const gp::Value& field(const gp::Struct& sample, const std::string& name) {
    return sample.fields().at("value").struct_value().fields().at(name);
  }
  std::map<std::string, std::string> types;
  std::map<std::string, std::vector<gp::Struct>> samples;
};

// Another party's generic tool: a reader with no type compiled in reads every topic of the link,
// catalog, descriptions, state and calls, and the devices' poses, with the types the bridges and
// devices announce in discovery (XTypes TypeObjects), each exactly as idl/dds/*.idl declares it.
TEST_F(PlainFederation, EveryTopicOfTheLinkReadsWithTypesAnnouncedAtRunTime) {
  Process reader({URS_DYNAMIC_READER_BIN, std::to_string(domain_), "urs/", "120"}, dir_ + "/dynamic_reader.log");
  auto reading = [&] { return DynamicReading(reader.log()); };
  // And the devices' own topics, on jp's devices domain.
  Process devices_reader({URS_DYNAMIC_READER_BIN, std::to_string(devices_domain()), "urs/", "120"},
                         dir_ + "/dynamic_reader_devices.log");
  ASSERT_TRUE(wait_for_service("jp/rt.Diagnostic0", 20s)) << kr_->log() << jp_->log();

  world::World devices(devices_domain(), "federation-test-robot");
  world::PoseSample pose;
  pose.robot = "robot1";
  pose.x = 1.25;
  pose.stamp = std::chrono::system_clock::now();
  world::PoseSample measured = pose;
  for (std::size_t i = 0; i < measured.covariance.size(); ++i) measured.covariance[i] = i % 4 == 0 ? 0.01 : 0;
  // Longer than fastddsgen's 255, which its type objects gave every unbounded string.
  const std::string note = "\"" + std::string(300, 'n') + "\"";
  ASSERT_EQ(urs({"context", "set", "room.note", note}).exit_code, 0);
  google::protobuf::Value alarm;
  alarm.set_number_value(7);
  // The request of an echo whose reply was seen too, or "".
  auto answered_request = [](const DynamicReading& now) -> std::string {
    for (const auto& request : now.with("urs/rpc/jp/request", "operation", "echo")) {
      const std::string id = DynamicReading::field(request, "request_id").string_value();
      if (!now.with("urs/rpc/kr/reply", "request_id", id).empty()) return id;
    }
    return "";
  };
  // Poses and events are volatile, calls retired once answered: each is sent until the reader,
  // which matches their writers in its own time, has one of every topic.
  EXPECT_TRUE(wait_until(
      [&] {
        devices.publish(world::Channel::ground_truth, pose);
        devices.publish(world::Channel::localizer, measured);
        planet_->publish("alarm/fire", alarm.SerializeAsString(), alarm.GetTypeName());
        URS::Diagnostic_echo_Request echo;
        echo.set_text("seen by a stranger");
        call("jp/rt.Diagnostic0", "echo", echo);
        const DynamicReading now = reading();
        return !now.with("urs/catalog", "name", "rt.Diagnostic0").empty() && now.samples.count("urs/interface") &&
               !now.with("urs/state/component", "name", "jphost.host_cxt/Diagnostic0.rtc").empty() &&
               !now.with("urs/state/pose", "robot", "robot1").empty() &&
               !now.with("urs/state/context", "key", "room.note").empty() &&
               !now.with("urs/state/event", "topic", "alarm/fire").empty() && !answered_request(now).empty();
      },
      60s))
      << reader.log();
  EXPECT_TRUE(wait_until(
      [&] {
        devices.publish(world::Channel::ground_truth, pose);
        devices.publish(world::Channel::localizer, measured);
        const DynamicReading now(devices_reader.log());
        return !now.with("urs/world/pose", "robot", "robot1").empty() &&
               !now.with("urs/localizer/pose", "robot", "robot1").empty();
      },
      30s))
      << devices_reader.log();
  const DynamicReading devices_seen(devices_reader.log());
  EXPECT_EQ(devices_seen.types.count("urs::dds::RobotPose") ? devices_seen.types.at("urs::dds::RobotPose") : "",
            "struct urs::dds::RobotPose { @key string robot; double x; double y; double theta; long long sec; "
            "unsigned long nsec; double sim_time; }");
  EXPECT_EQ(devices_seen.types.count("urs::dds::RobotPoseEstimate")
                ? devices_seen.types.at("urs::dds::RobotPoseEstimate")
                : "",
            "struct urs::dds::RobotPoseEstimate { @key string robot; double x; double y; double theta; "
            "double covariance[9]; long long sec; unsigned long nsec; }");
  const auto estimates = devices_seen.with("urs/localizer/pose", "robot", "robot1");
  ASSERT_FALSE(estimates.empty());
  const auto& covariance = DynamicReading::field(estimates[0], "covariance").list_value();
  ASSERT_EQ(covariance.values_size(), 9);
  EXPECT_EQ(covariance.values(4).number_value(), 0.01);
  EXPECT_EQ(covariance.values(5).number_value(), 0);

  const DynamicReading seen = reading();
  const std::map<std::string, std::string> idl{
      {"urs::dds::ServiceEntry",
       "struct urs::dds::ServiceEntry { @key string space; @key string name; string interface_name; "
       "string repository_id; string origin; string bridge; unsigned long deadline_ms; string interface_digest; }"},
      {"urs::dds::InterfaceDescription",
       "struct urs::dds::InterfaceDescription { @key string digest; sequence<octet> descriptor_set; }"},
      {"urs::dds::CallRequest",
       "struct urs::dds::CallRequest { @key string request_id; string caller_space; string service; "
       "string operation; unsigned long deadline_ms; boolean no_reply; sequence<octet> payload; string caller_name; "
       "string traceparent; }"},
      {"urs::dds::CallReply",
       "struct urs::dds::CallReply { @key string request_id; long status; string message; string exception_type; "
       "sequence<octet> payload; }"},
      {"urs::dds::ComponentState",
       "struct urs::dds::ComponentState { @key string space; @key string name; string kind; string state; "
       "string type_name; string host; long long sec; unsigned long nsec; }"},
      {"urs::dds::SpacePose",
       "struct urs::dds::SpacePose { @key string space; @key string robot; double x; double y; double theta; "
       "long long sec; unsigned long nsec; }"},
      {"urs::dds::ContextEntry",
       "struct urs::dds::ContextEntry { @key string space; @key string key; string value_json; string source; "
       "unsigned long long version; long long sec; unsigned long nsec; }"},
      {"urs::dds::SpaceEvent",
       "struct urs::dds::SpaceEvent { string space; unsigned long long seq; string topic; string content_type; "
       "string source; long long sec; unsigned long nsec; sequence<octet> payload; }"}};
  for (const auto& [name, declaration] : idl) {
    EXPECT_EQ(seen.types.count(name) ? seen.types.at(name) : "(not announced)", declaration);
  }

  // The values, as the bridges wrote them.
  const auto entries = seen.with("urs/catalog", "name", "rt.Diagnostic0");
  ASSERT_FALSE(entries.empty()) << reader.log();
  EXPECT_EQ(DynamicReading::field(entries[0], "space").string_value(), "jp");
  EXPECT_EQ(DynamicReading::field(entries[0], "interface_name").string_value(), "URS.Diagnostic");
  const std::string digest = DynamicReading::field(entries[0], "interface_digest").string_value();
  const auto descriptions = seen.with("urs/interface", "digest", digest);
  ASSERT_FALSE(descriptions.empty()) << digest;
  gp::BytesValue descriptor_set;  // JSON's form of bytes is base64, as the reader prints them
  ASSERT_TRUE(
      gp::util::JsonStringToMessage(
          "\"" + DynamicReading::field(descriptions[0], "descriptor_set").string_value() + "\"", &descriptor_set)
          .ok());
  gp::FileDescriptorSet files;
  ASSERT_TRUE(files.ParseFromString(descriptor_set.value()));
  bool described = false;
  for (const auto& file : files.file()) {
    for (const auto& service : file.service()) described |= file.package() + "." + service.name() == "URS.Diagnostic";
  }
  EXPECT_TRUE(described) << files.DebugString();
  EXPECT_FALSE(seen.with("urs/state/component", "name", "jphost.host_cxt/Diagnostic0.rtc").empty());
  const auto poses = seen.with("urs/state/pose", "robot", "robot1");
  ASSERT_FALSE(poses.empty());
  EXPECT_EQ(DynamicReading::field(poses[0], "x").number_value(), 1.25);
  const auto notes = seen.with("urs/state/context", "key", "room.note");
  ASSERT_FALSE(notes.empty());
  EXPECT_EQ(DynamicReading::field(notes.back(), "value_json").string_value(), note);
  EXPECT_FALSE(seen.with("urs/state/event", "topic", "alarm/fire").empty());
  const std::string request_id = answered_request(seen);
  ASSERT_FALSE(request_id.empty());
  const auto request = seen.with("urs/rpc/jp/request", "request_id", request_id)[0];
  EXPECT_EQ(DynamicReading::field(request, "service").string_value(), "rt.Diagnostic0");
  EXPECT_EQ(DynamicReading::field(request, "caller_space").string_value(), "kr");
  const auto replies = seen.with("urs/rpc/kr/reply", "request_id", request_id);
  EXPECT_EQ(DynamicReading::field(replies[0], "status").number_value(), 0);
}

// A raw participant of the link (a member on a secured link, with the files of `security`)
// reading requests and writing replies on call topics of its choosing: an eavesdropper, a forger.
class RpcPeer {
 public:
  RpcPeer(uint32_t domain, const federation::DdsSecurity& security) {
    namespace fdds = eprosima::fastdds::dds;
    participant_ = join_link(domain, security);
    request_type_.register_type(participant_);
    reply_type_.register_type(participant_);
    qos_.reliability().kind = fdds::RELIABLE_RELIABILITY_QOS;
    qos_.durability().kind = fdds::TRANSIENT_LOCAL_DURABILITY_QOS;
    qos_.history().kind = fdds::KEEP_ALL_HISTORY_QOS;
  }
  ~RpcPeer() {
    participant_->delete_contained_entities();
    eprosima::fastdds::dds::DomainParticipantFactory::get_instance()->delete_participant(participant_);
  }
  // Reads the requests written on `topic` from now on.
  bool read_requests(const std::string& topic) {
    namespace fdds = eprosima::fastdds::dds;
    auto* made = participant_->create_topic(topic, request_type_.get_type_name(), fdds::TOPIC_QOS_DEFAULT);
    fdds::DataReaderQos qos = fdds::DATAREADER_QOS_DEFAULT;
    qos.reliability().kind = fdds::RELIABLE_RELIABILITY_QOS;
    qos.history().kind = fdds::KEEP_ALL_HISTORY_QOS;
    reader_ =
        made ? participant_->create_subscriber(fdds::SUBSCRIBER_QOS_DEFAULT)->create_datareader(made, qos) : nullptr;
    return reader_ != nullptr;
  }
  // The requests read so far.
  const std::vector<dds::CallRequest>& requests() {
    dds::CallRequest sample;
    eprosima::fastdds::dds::SampleInfo info;
    while (reader_->take_next_sample(&sample, &info) == ReturnCode_t::RETCODE_OK) {
      if (info.valid_data) requests_.push_back(sample);
    }
    return requests_;
  }
  // Writes replies on `topic` from now on.
  bool write_replies(const std::string& topic) {
    namespace fdds = eprosima::fastdds::dds;
    auto* made = participant_->create_topic(topic, reply_type_.get_type_name(), fdds::TOPIC_QOS_DEFAULT);
    writer_ =
        made ? participant_->create_publisher(fdds::PUBLISHER_QOS_DEFAULT)->create_datawriter(made, qos_) : nullptr;
    return writer_ != nullptr;
  }
  // True once the reply writer matches a reader (the caller's bridge).
  bool replies_matched() const {
    eprosima::fastdds::dds::PublicationMatchedStatus status;
    writer_->get_publication_matched_status(status);
    return status.current_count > 0;
  }
  bool reply(dds::CallReply reply) { return writer_->write(&reply); }
  // True once the request reader matches a writer (a caller's bridge).
  bool requests_matched() const {
    eprosima::fastdds::dds::SubscriptionMatchedStatus status;
    reader_->get_subscription_matched_status(status);
    return status.current_count > 0;
  }

 private:
  eprosima::fastdds::dds::DomainParticipant* participant_ = nullptr;
  eprosima::fastdds::dds::TypeSupport request_type_{new dds::CallRequestPubSubType()};
  eprosima::fastdds::dds::TypeSupport reply_type_{new dds::CallReplyPubSubType()};
  eprosima::fastdds::dds::DataWriterQos qos_ = eprosima::fastdds::dds::DATAWRITER_QOS_DEFAULT;
  eprosima::fastdds::dds::DataReader* reader_ = nullptr;
  eprosima::fastdds::dds::DataWriter* writer_ = nullptr;
  std::vector<dds::CallRequest> requests_;
};

// Only the called space answers a call. Member "spy" learns the id of a call kr makes to jp (from
// a participant of jp's, which reads jp's requests) and answers it on kr's reply topic before jp
// does: kr's bridge ignores the forged reply (logged once) and its caller gets jp's.
TEST_F(AuthorizedFederation, AReplyFromAnotherMemberThanTheCalledSpaceIsIgnored) {
  ASSERT_TRUE(wait_for_service("jp/rt.Diagnostic0", 20s)) << kr_->log() << jp_->log();
  RpcPeer jp_reader(static_cast<uint32_t>(domain_), federation::security_from_folder(*pki_, "jp"));
  ASSERT_TRUE(jp_reader.read_requests("urs/rpc/jp/request"));
  RpcPeer spy(static_cast<uint32_t>(domain_), federation::security_from_folder(*pki_, "spy"));
  ASSERT_TRUE(spy.write_replies("urs/rpc/kr/reply"));
  ASSERT_TRUE(wait_until([&] { return spy.replies_matched(); }, 20s)) << kr_->log();
  // kr's request writer to jp exists once kr has called jp.
  ASSERT_NO_FATAL_FAILURE(expect_echo("jp/rt.Diagnostic0", "first"));
  ASSERT_TRUE(wait_until([&] { return jp_reader.requests_matched(); }, 20s)) << kr_->log();

  auto outcome = std::make_shared<std::promise<planet::CallResult>>();
  URS::Diagnostic_sleep_Request sleep;
  // Long enough for the spy to see the request and answer first on a loaded machine; under the 5 s
  // deadline of jp's provider rule (the fixture's).
  sleep.set_ms(4500);
  planet_->call_async("jp/rt.Diagnostic0", "sleep", sleep.SerializeAsString(), 20s,
                      [outcome](planet::CallResult result) { outcome->set_value(std::move(result)); });
  std::string id;
  ASSERT_TRUE(wait_until(
      [&] {
        for (const auto& request : jp_reader.requests()) {
          if (request.operation() == "sleep") id = request.request_id();
        }
        return !id.empty();
      },
      4s))
      << kr_->log();
  for (int i = 0; i < 2; ++i) {
    dds::CallReply forged;
    forged.request_id(id);
    forged.status(call::status_number(call::Status::INTERNAL));
    forged.message("answered by spy");
    ASSERT_TRUE(spy.reply(forged));
  }

  auto answer = outcome->get_future();
  ASSERT_EQ(answer.wait_for(20s), std::future_status::ready);
  const planet::CallResult result = answer.get();
  EXPECT_EQ(result.status, planet::OK) << result.message;
  EXPECT_EQ(count_of(kr_->log(), "a member proven as spy announced space jp's reply to jp/" + id + ": ignored"), 1u)
      << kr_->log();
}

}  // namespace
}  // namespace urs::test
