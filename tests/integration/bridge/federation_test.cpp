// Two spaces linked only over DDS (real Fast DDS participants, UDP only, as between containers):
// "jp" is an RT-Middleware space (omniNames, urs-rtc-manager with a Diagnostic RTC, urs-bridge
// with no CAMUS server) and "kr" a CAMUS space (urs-camus-server, urs-sam with the diagnostic
// agent, urs-bridge with no naming service). Each space's services are callable from the other
// under the other space's prefix; a dead bridge's services vanish within the lease and return
// with it; a restarted CAMUS server gets the imported services back; filters and loop prevention
// keep the catalogs as configured. The spaces also share state: jp's RTC lifecycle states and
// robot poses reach kr's context, kr's agents, context entries and events reach any DDS reader
// (here a third "space" observing the link), and a lost bridge's state ends with it.

#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <future>
#include <iostream>

#include <google/protobuf/struct.pb.h>

#include <mutex>

#include "Diagnostic.pb.h"
#include "bridge_fixture.hpp"
#include "dds_domain.hpp"
#include "camus.pb.h"
#include "urs/bridge/state_link.hpp"
#include "urs/corba_agent/corba_proxy.hpp"
#include "urs/world/world.hpp"

namespace urs::test {
namespace {

using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;
namespace gp = google::protobuf;

constexpr auto kLease = 1500ms;

class Federation : public BridgeSpaceTest {
 protected:
  void SetUp() override {
    space_ = "kr";
    BridgeSpaceTest::SetUp();
    if (HasFatalFailure()) return;
    domain_ = static_cast<int>(domains_[0]);  // tests running side by side stay apart
    start_manager("m", "jphost", "components:\n  - type: Diagnostic\n  - type: Diagnostic\n    instance: Secret0\n");
    start_jp();
    start_kr();
  }

  void start_kr(const std::string& discovery = "") {
    kr_ = launch_bridge("bridge-kr",
                        "name: bridge-kr\n" + dds(discovery) +
                            "  export: {allow: [\"*\"], deny: []}\n"
                            "  import: {as_rtc: \"\"}\n"
                            "  state: {events: [\"alarm/#\"], context: {allow: [\"room.*\"]}}\n",
                        {"--server", server_address_});
  }

  void TearDown() override {
    if (HasFailure()) {
      std::cerr << "---- bridge-jp log\n" << (jp_ ? jp_->log() : "") << "---- bridge-kr log\n" << (kr_ ? kr_->log() : "");
    }
    jp_.reset();
    kr_.reset();
    BridgeSpaceTest::TearDown();
  }

  std::string dds(const std::string& discovery = "") const {
    return "dds:\n  domain: " + std::to_string(domain_) + "\n  lease_ms: " + std::to_string(kLease.count()) +
           "\n  udp_only: true\n" + discovery;
  }

  void start_jp(const std::string& discovery = "") {
    jp_ = launch_bridge("bridge-jp",
                        "name: bridge-jp\n"
                        "rt_to_camus:\n"
                        "  poll_ms: 100\n"
                        "  providers:\n"
                        "    - {match: \"*\", name: \"rt.{instance}\", deadline_ms: 5000}\n" +
                            dds(discovery) + "  export: {deny: [\"rt.Secret*\"]}\n" +
                            "  state: {period_ms: 100, poses: {domain: " + std::to_string(devices_domain()) +
                            ", source: ground_truth, robots: [robot1], period_ms: 20}}\n",
                        {"--naming", naming_->address(), "--host", "jphost"}, "jp");
  }

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

  // kr's CAMUS server killed and started again on its port, with its data.
  void restart_server() {
    const std::string port = server_address_.substr(server_address_.rfind(':') + 1);
    server_->kill9();
    server_ = std::make_unique<Process>(
        std::vector<std::string>{URS_SERVER_BIN, "--space", space_, "--listen", "127.0.0.1:" + port, "--data-dir",
                                 dir_ + "/data", "--heartbeat-ms", "200", "--heartbeat-timeout-ms", "1000"},
        dir_ + "/server2.log");
  }

  // A UDP port nothing listens on now.
  static uint16_t free_udp_port() {
    const int fd = socket(AF_INET, SOCK_DGRAM, 0);
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

TEST_F(Federation, EachSpacesServicesAreCallableFromTheOther) {
  ASSERT_TRUE(wait_for_service("jp/rt.Diagnostic0", 20s)) << kr_->log() << jp_->log();
  EXPECT_NE(listed("jp/rt.Diagnostic0").find("dds:jp/rt.Diagnostic0"), std::string::npos);

  // kr's CAMUS client -> kr server -> bridge-kr -DDS-> bridge-jp -CORBA-> jp's RTC.
  ASSERT_NO_FATAL_FAILURE(expect_echo("jp/rt.Diagnostic0", "こんにちは from kr"));

  URS::Diagnostic_blob_Request blob;  // an image-sized reply crosses whole
  blob.set_size(921600);
  const auto started = Clock::now();
  const Observed image = call("jp/rt.Diagnostic0", "blob", blob);
  std::cout << "921600-byte reply across spaces: "
            << std::chrono::duration_cast<std::chrono::microseconds>(Clock::now() - started).count() << " us\n";
  ASSERT_EQ(image.status, planet::OK) << image.message;
  URS::Diagnostic_blob_Reply bytes;
  ASSERT_TRUE(bytes.ParseFromString(image.payload));
  ASSERT_EQ(bytes.result().size(), 921600u);
  for (std::size_t i = 0; i < bytes.result().size(); i += 4099) {
    ASSERT_EQ(static_cast<unsigned char>(bytes.result()[i]), i % 251) << "byte " << i;
  }

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
  const auto slept = Clock::now();
  EXPECT_EQ(call("jp/rt.Diagnostic0", "sleep", sleep, 400ms).status, planet::DEADLINE_EXCEEDED);
  EXPECT_LT(Clock::now() - slept, 2500ms);

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
  corba_agent::CorbaProxyAgent consumer(test_orb().orb(), provider,
                                        *URS::Diagnostic_echo_Request::descriptor()->file()->FindServiceByName("Diagnostic"));
  agent::CallContext ctx;
  ctx.deadline = Clock::now() + 5s;
  URS::Diagnostic_echo_Request from_jp;
  from_jp.set_text("from jp's RT side");
  URS::Diagnostic_echo_Reply to_jp;
  const agent::Outcome outcome =
      consumer.invoke(*consumer.interface().FindMethodByName("echo"), from_jp, to_jp, ctx);
  EXPECT_EQ(outcome.status, planet::OK) << outcome.message;
  EXPECT_EQ(to_jp.result(), "from jp's RT side");
}

TEST_F(Federation, ADeadBridgesServicesVanishWithinTheLeaseAndReturnWithIt) {
  ASSERT_TRUE(wait_for_service("jp/rt.Diagnostic0", 20s)) << kr_->log();
  jp_->kill9();
  const auto killed = Clock::now();
  ASSERT_TRUE(wait_service_gone("jp/rt.Diagnostic0", 15s)) << kr_->log();
  const auto vanished = Clock::now() - killed;
  std::cout << "jp's services vanished from kr "
            << std::chrono::duration_cast<std::chrono::milliseconds>(vanished).count() << " ms after the kill (lease "
            << kLease.count() << " ms)\n";
  EXPECT_LT(vanished, kLease * 4);
  // Calls fail at once with a clear error rather than waiting for their deadline.
  URS::Diagnostic_echo_Request echo;
  const auto asked = Clock::now();
  const Observed failed = call("jp/rt.Diagnostic0", "echo", echo, 5s);
  EXPECT_EQ(failed.status, planet::UNKNOWN_SERVICE) << failed.message;
  EXPECT_LT(Clock::now() - asked, 1000ms);

  start_jp();
  ASSERT_TRUE(wait_for_service("jp/rt.Diagnostic0", 20s)) << kr_->log();
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

// Sites that pass no multicast: bridge-jp is a Fast DDS discovery server, bridge-kr its client
// (a client discovers nothing but through its servers), and the spaces link as before.
TEST_F(Federation, SpacesLinkThroughADiscoveryServer) {
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

// What a third space sees of the others' state over DDS: a plain participant of the link.
struct StateObserver {
  explicit StateObserver(uint32_t domain, std::chrono::milliseconds lease) {
    bridge::DdsOptions options;
    options.domain = domain;
    options.space = "obs";
    options.bridge = "observer";
    options.lease = lease;
    options.udp_only = true;
    link = std::make_unique<bridge::DdsLink>(options, [] {}, [](bridge::IncomingCall, auto) {});
    bridge::StateHandlers handlers;
    handlers.component = [this](const bridge::ComponentState& c, bool alive) {
      std::lock_guard lock(mutex);
      if (alive) {
        components[c.space + "/" + c.name] = c;
      } else {
        components.erase(c.space + "/" + c.name);
      }
    };
    handlers.context = [this](const bridge::ContextState& e, bool alive) {
      std::lock_guard lock(mutex);
      if (alive) {
        context[e.space + "/" + e.key] = e.value_json;
      } else {
        context.erase(e.space + "/" + e.key);
      }
    };
    handlers.event = [this](const bridge::SpaceEvent& e) {
      std::lock_guard lock(mutex);
      events.push_back(e);
    };
    state = std::make_unique<bridge::StateLink>(*link, handlers, std::nullopt);
  }
  template <class F>
  auto with(F f) {
    std::lock_guard lock(mutex);
    return f();
  }

  std::mutex mutex;
  std::map<std::string, bridge::ComponentState> components;
  std::map<std::string, std::string> context;
  std::vector<bridge::SpaceEvent> events;
  std::unique_ptr<bridge::DdsLink> link;
  std::unique_ptr<bridge::StateLink> state;  // last: destroyed first
};

TEST_F(Federation, SpacesShareStateOverDds) {
  StateObserver observer(static_cast<uint32_t>(domain_), kLease);
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

  // kr's agents and the context entries it allows reach the observer; those it denies do not.
  EXPECT_TRUE(wait_until([&] { return observer.with([&] { return observer.components.count("kr/diag") == 1; }); }, 20s));
  EXPECT_EQ(observer.with([&] { return observer.components["kr/diag"].kind; }), "agent");
  EXPECT_EQ(observer.with([&] { return observer.components["kr/diag"].state; }), "Available");
  EXPECT_TRUE(wait_until([&] { return observer.with([&] { return observer.components.count("jp/" + diag) == 1; }); }, 10s));
  ASSERT_EQ(urs({"context", "set", "room.temperature", "21.5"}).exit_code, 0);
  ASSERT_EQ(urs({"context", "set", "secret.code", "\"1234\""}).exit_code, 0);
  EXPECT_TRUE(wait_until([&] { return observer.with([&] { return observer.context.count("kr/room.temperature") == 1; }); },
                         10s));
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
  start_jp();
  EXPECT_TRUE(wait_until([&] { return context_field("jp/component/" + diag, "state") == "Inactive"; }, 20s));
}

}  // namespace
}  // namespace urs::test
