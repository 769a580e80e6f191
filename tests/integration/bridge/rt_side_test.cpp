// The bridge seen from the RT side: a CAMUS service offered by urs-bridge is an RT-Component in
// the naming service whose provider port RT consumers connect to and call through the ordinary
// static stubs; it comes and goes with its agent; deactivating the bridge RTC withdraws both
// directions and activating it restores them, with nothing bridged twice; CAMUS events feed an
// RT InPort. Real omniNames, urs-camus-server, urs-sam, urs-rtc-manager and urs-bridge.

#include <gtest/gtest.h>

#include <csignal>

#include "BasicDataType.hh"
#include "Diagnostic.hh"
#include "bridge_fixture.hpp"
#include "urs/rtc/data_port.hpp"
#include "urs/rtc/execution_context.hpp"
#include "urs/rtc/manager.hpp"
#include "urs/rtc/nvlist.hpp"
#include "urs/schema/schema.hpp"

namespace urs::test {
namespace {

using namespace std::chrono_literals;

constexpr const char* kImportPath = "bridgehost.host_cxt/camus_diag.rtc";

class BridgeRtSide : public BridgeSpaceTest {
 protected:
  // A consumer of this process connected to the port of the RTC standing for diag.
  URS::Diagnostic_var connect_consumer() {
    consumer_ = std::make_unique<DiagnosticConsumer>("Consumer", "diagnostic");
    consumer_->setup(test_orb(), "Consumer0", 10);
    EXPECT_EQ(consumer_->initialize(), RTC::RTC_OK);
    auto rtc = resolve<RTC::RTObject>(kImportPath);
    RTC::PortService_var provider = rtc::find_port(rtc, "diagnostic");
    EXPECT_FALSE(CORBA::is_nil(provider));
    RTC::PortService_var ours = consumer_->port();
    const auto made = rtc::connect_ports({ours.in(), provider.in()}, "test");
    EXPECT_EQ(made.code, RTC::RTC_OK);
    return consumer_->consumer().get<URS::Diagnostic>();
  }

  // diag's SAM is killed (SIGKILL): the RTC standing for diag leaves the naming service; started
  // again, the RTC comes back.
  void sam_dies_and_returns() {
    sam_->kill9();
    EXPECT_TRUE(wait_until([&] { return !bound(kImportPath); }, 15s)) << bridge_->log();
    sam_ = std::make_unique<Process>(std::vector<std::string>{URS_SAM_BIN, "--space", "lab", "--server",
                                                              server_address_, "--config", dir_ + "/sam.yaml"},
                                     dir_ + "/sam2.log");
    EXPECT_TRUE(wait_until([&] { return bound(kImportPath); }, 15s)) << bridge_->log();
  }

  void TearDown() override {
    if (consumer_) consumer_->exit();
    consumer_.reset();
    BridgeSpaceTest::TearDown();
  }

  // Sets the bridge RTC's state through its execution context, as `urs rtc act/deact` does.
  void set_bridge_active(bool active) {
    auto bridge = resolve<RTC::RTObject>("bridgehost.host_cxt/Bridge0.rtc");
    RTC::ExecutionContextList_var contexts = bridge->get_owned_contexts();
    ASSERT_EQ(contexts->length(), 1u);
    const auto code = active ? contexts[0]->activate_component(bridge) : contexts[0]->deactivate_component(bridge);
    ASSERT_EQ(code, RTC::RTC_OK);
  }

  // Fences for rules that match everything. A fence is a service that appears after the state the
  // test checks and then leaves: the poll of the bridge that offered it began after that state, and
  // a later poll withdrew it, so the first had finished by then, with all it would do about the
  // state. No fixed sleep guesses how many polls are enough.
  void pass_camus_to_rt_fence() {
    std::ofstream(dir_ + "/fence.yaml") << "agents:\n  - name: fence\n    type: diagnostic\n";
    Process fence({URS_SAM_BIN, "--space", space_, "--server", server_address_, "--config", dir_ + "/fence.yaml"},
                  dir_ + "/fence-sam.log");
    const std::string path = "bridgehost.host_cxt/camus_fence.rtc";
    ASSERT_TRUE(wait_until([&] { return bound(path); }, 15s)) << bridge_->log() << fence.log();
    fence.signal(SIGTERM);
    EXPECT_EQ(fence.wait(10s), 0) << fence.log();
    ASSERT_TRUE(wait_until([&] { return !bound(path); }, 15s)) << bridge_->log();
  }
  void pass_rt_to_camus_fence() {
    start_manager("fence", "labhost", "components:\n  - type: Diagnostic\n    instance: Fence\n");
    ASSERT_TRUE(wait_for_service("rt.Fence")) << bridge_->log();
    manager("fence").signal(SIGTERM);
    EXPECT_EQ(manager("fence").wait(10s), 0);
    ASSERT_TRUE(wait_service_gone("rt.Fence")) << bridge_->log();
  }

  std::unique_ptr<DiagnosticConsumer> consumer_;
};

TEST_F(BridgeRtSide, CamusServiceIsAProviderThatRtConsumersCall) {
  start_bridge(
      "name: bridge-test\n"
      "camus_to_rt:\n"
      "  poll_ms: 100\n"
      "  services:\n"
      "    - match: diag\n"
      "      instance: \"camus_{service}\"\n"
      "      deadline_ms: 1000\n");
  ASSERT_TRUE(wait_until([&] { return bound(kImportPath); }, 15s)) << bridge_->log();
  auto rtc = resolve<RTC::RTObject>(kImportPath);
  RTC::ComponentProfile_var profile = rtc->get_component_profile();
  EXPECT_EQ(rtc::nv_string(profile->properties, "urslink.origin").value_or(""), "camus:diag");

  URS::Diagnostic_var diag = connect_consumer();
  ASSERT_FALSE(CORBA::is_nil(diag));
  CORBA::String_var echoed = diag->echo("héllo from RT");
  EXPECT_STREQ(echoed.in(), "héllo from RT");
  EXPECT_DOUBLE_EQ(diag->add(2, 0.5), 2.5);
  URS::OctetSeq_var blob = diag->blob(921600);
  ASSERT_EQ(blob->length(), 921600u);
  EXPECT_EQ(blob[1000], 1000 % 251);
  try {
    diag->fail("no battery", 7);
    ADD_FAILURE() << "fail() returned";
  } catch (const URS::Failure& e) {
    EXPECT_STREQ(e.reason.in(), "no battery");
    EXPECT_EQ(e.code, 7);
  }
  // The configured deadline (1000 ms) bounds a call the agent would take 3 s for.
  EXPECT_THROW(diag->sleep(3000), CORBA::TIMEOUT);
  EXPECT_STREQ(CORBA::String_var(diag->echo("still there")).in(), "still there");

  // The agent's SAM dies: the service leaves the registry and its RTC leaves the naming service.
  sam_dies_and_returns();
}

// The CAMUS registry is read when the server says it changed (registry/<name> events), not only
// at the poll: with a poll of a minute, a service's RTC still leaves with its SAM and comes back
// with it within seconds.
TEST_F(BridgeRtSide, ARegistryChangeReachesTheRtSideWithoutWaitingForThePoll) {
  start_bridge(
      "name: bridge-test\n"
      "camus_to_rt:\n"
      "  poll_ms: 60000\n"
      "  services:\n"
      "    - match: diag\n"
      "      instance: \"camus_{service}\"\n");
  ASSERT_TRUE(wait_until([&] { return bound(kImportPath); }, 15s)) << bridge_->log();
  sam_dies_and_returns();
}

TEST_F(BridgeRtSide, DeactivationWithdrawsBothDirectionsAndNothingIsBridgedTwice) {
  start_manager("m", "labhost", "components:\n  - type: Diagnostic\n");
  // Rules that match everything: what the bridge offers must not come back through it.
  start_bridge(
      "name: bridge-test\n"
      "rt_to_camus:\n"
      "  poll_ms: 100\n"
      "  providers:\n"
      "    - match: \"*\"\n"
      "      name: \"rt.{instance}\"\n"
      "camus_to_rt:\n"
      "  poll_ms: 100\n"
      "  services:\n"
      "    - match: \"*\"\n"
      "      instance: \"camus_{service}\"\n");
  ASSERT_TRUE(wait_for_service("rt.Diagnostic0")) << bridge_->log();
  ASSERT_TRUE(wait_until([&] { return bound(kImportPath); }, 15s)) << bridge_->log();
  // Nothing may come back through the bridge. Every poll that could have bridged something back
  // has run once a fence has passed each direction in turn.
  pass_camus_to_rt_fence();
  pass_rt_to_camus_fence();
  if (HasFatalFailure()) return;
  auto r = urs({"ls"});
  EXPECT_EQ(r.out.find("rt.camus_diag"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("rt.Bridge0"), std::string::npos) << r.out;
  EXPECT_FALSE(bound("bridgehost.host_cxt/camus_rt_Diagnostic0.rtc"));
  EXPECT_FALSE(bound("bridgehost.host_cxt/camus_camus_registry.rtc"));  // the server's built-ins stay home

  set_bridge_active(false);
  EXPECT_TRUE(wait_service_gone("rt.Diagnostic0")) << bridge_->log();
  EXPECT_TRUE(wait_until([&] { return !bound(kImportPath); }, 10s)) << bridge_->log();
  EXPECT_TRUE(bound("bridgehost.host_cxt/Bridge0.rtc"));  // the bridge itself stays, inactive

  set_bridge_active(true);
  EXPECT_TRUE(wait_for_service("rt.Diagnostic0")) << bridge_->log();
  EXPECT_TRUE(wait_until([&] { return bound(kImportPath); }, 10s)) << bridge_->log();
}

// An RTC of this process with an InPort of RTC::TimedLong named "count".
class Probe : public rtc::Component {
 public:
  Probe() : Component({"Probe", "test InPort", "1.0", "URSLink", "Test"}), count_("count") {}
  rtc::InPort<RTC::TimedLong>& count() { return count_; }

 protected:
  RTC::ReturnCode_t handle_initialize() override {
    add_port(count_);
    return RTC::RTC_OK;
  }

 private:
  rtc::InPort<RTC::TimedLong> count_;
};

TEST_F(BridgeRtSide, CamusEventsFeedAnRtInPort) {
  rtc::Manager host(test_orb(), *client_, {"lab", "testhost", 10});
  Probe* probe = nullptr;
  host.create({"Probe", "", 0, false, {}, {}}, [&](const YAML::Node&, const rtc::ComponentEnv&) {
    auto made = std::make_unique<Probe>();
    probe = made.get();
    return made;
  });
  const std::string types = std::string(URS_RTC_IDL_DIR) + "/BasicDataType.idl";
  start_bridge(
      "name: bridge-test\n"
      "idl: [" +
      types +
      "]\n"
      "rt_to_camus: {poll_ms: 100}\n"
      "events_to_rt:\n"
      "  - topic: \"feed/#\"\n"
      "    type: RTC.TimedLong\n"
      "    match: \"*/Probe*.rtc\"\n"
      "    port: count\n");
  ASSERT_TRUE(wait_until([&] { return probe->count().connection_count() == 1; }, 15s)) << bridge_->log();

  const schema::IdlLoad loaded = schema::load_idl(types);
  ASSERT_TRUE(loaded.ok()) << loaded.error;
  schema::SchemaPool pool;
  ASSERT_EQ(pool.add_descriptor_set(loaded.descriptor_set), "");
  const auto* timed_long = pool.find_message("RTC.TimedLong");
  ASSERT_NE(timed_long, nullptr);
  planet_->publish("feed/other", "not a TimedLong", "text/plain");  // another type on the topic: skipped
  // Five values, then a sixth as the last word: events reach the InPort in order, one at a time,
  // so once the sixth is in, anything the bridge wrongly forwarded (the other type, a repeat) is in too.
  for (int i = 1; i <= 6; ++i) {
    auto value = pool.new_message(*timed_long);
    value->GetReflection()->SetInt32(value.get(), timed_long->FindFieldByName("data"), i * 100);
    ASSERT_TRUE(planet_->publish("feed/count", value->SerializeAsString(), "RTC.TimedLong").ok());
  }
  ASSERT_TRUE(wait_until([&] { return probe->count().received() >= 6; }, 10s)) << bridge_->log();
  EXPECT_EQ(probe->count().received(), 6u);
  for (int i = 1; i <= 6; ++i) {
    RTC::TimedLong value;
    ASSERT_TRUE(probe->count().read(value));
    EXPECT_EQ(value.data, i * 100);
  }
  host.shutdown();
}

}  // namespace
}  // namespace urs::test
