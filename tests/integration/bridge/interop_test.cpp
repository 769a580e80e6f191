// What unmodified OpenRTM-aist peers showed the bridge, reproduced with URSLink's own runtime in
// real processes (omniNames, urs-rtc-manager, urs-camus-server, urs-sam, urs-bridge, urs): a call
// without a deadline gets the one the service advertises, even above the client's old 10 s; slow
// calls to a provider hold up no other up to the bridge's calls per peer, and a call beyond them
// waits within its deadline; a provider paused with SIGSTOP is slow, not gone, and serves again;
// a dropped connection is dropped on both ends, so that the ports, which refuse duplicate
// connections as OpenRTM-aist's do, connect again; an Inactive provider (whose objects do not
// exist, as in OpenRTM-aist) is listed as such and calls say how to activate it; bounded
// references keep their own timeouts; a restarted bridge connects its RTCs' consumers again; the
// references the bridge and the manager hand out carry their repository ID and an address the
// naming service's peers reach.

#include <gtest/gtest.h>
#include <signal.h>

#include <sstream>
#include <thread>

#include "Diagnostic.hh"
#include "bridge_fixture.hpp"
#include "urs/rtc/nvlist.hpp"

namespace urs::test {
namespace {

using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;

constexpr const char* kProviderPath = "labhost.host_cxt/Diagnostic0.rtc";
constexpr const char* kImportPath = "bridgehost.host_cxt/camus_diag.rtc";
constexpr const char* kImportRules =
    "name: bridge-test\n"
    "rt_to_camus: {poll_ms: 100}\n"
    "camus_to_rt:\n"
    "  poll_ms: 100\n"
    "  services:\n"
    "    - match: diag\n"
    "      instance: \"camus_{service}\"\n"
    "      deadline_ms: 2000\n";

// What catior (omniORB's tool, a reader that is not URSLink) says of an IOR.
struct Catior {
  std::string type_id;
  std::string host;
  int port = 0;
};
Catior catior(const std::string& ior) {
  const CommandResult r = run_command({"/usr/bin/catior", ior}, 10s);
  Catior parsed;
  std::istringstream lines(r.out);
  for (std::string line; std::getline(lines, line);) {
    if (line.rfind("Type ID: \"", 0) == 0) parsed.type_id = line.substr(10, line.rfind('"') - 10);
    const auto iiop = line.find("IIOP 1.");
    if (iiop != std::string::npos && parsed.host.empty()) {
      std::istringstream words(line.substr(iiop));
      std::string tag, version;
      words >> tag >> version >> parsed.host >> parsed.port;
    }
  }
  return parsed;
}

class BridgeInterop : public BridgeSpaceTest {
 protected:
  // The STATE column of `urs ls` for `name` ("" if it is not listed).
  std::string state_of(const std::string& name) {
    std::istringstream columns(listed(name));
    std::string service, interface, owner, peer, state;
    columns >> service >> interface >> owner >> peer >> state;
    return state;
  }
  bool wait_state(const std::string& name, const std::string& state, std::chrono::milliseconds timeout = 15s) {
    return wait_until([&] { return state_of(name) == state; }, timeout);
  }
  CommandResult echo(const std::string& service) { return urs({"call", service, "echo", R"({"text":"hi"})"}); }

  // `count` calls of `urs call rt.Diagnostic0 sleep` of `ms` each, in processes of their own, once
  // the provider has begun every one of them (its log says so); empty if it did not within 15 s.
  std::vector<std::unique_ptr<Process>> sleeping(int count, int ms) {
    std::vector<std::unique_ptr<Process>> calls;
    const std::string args = R"({"ms":)" + std::to_string(ms) + "}";
    for (int i = 0; i < count; ++i) {
      std::vector<std::string> argv{URS_CLI_BIN, "--server", server_address_};
      const std::vector<std::string> token = admin_token_args();
      argv.insert(argv.end(), token.begin(), token.end());
      argv.insert(argv.end(), {"call", "rt.Diagnostic0", "sleep", args});
      calls.push_back(std::make_unique<Process>(argv, dir_ + "/sleep" + std::to_string(i) + ".log"));
    }
    const std::string begun = "sleep " + std::to_string(ms) + " ms begins";
    const auto begun_count = [&] {
      const std::string log = manager("m").log();
      int found = 0;
      for (auto at = log.find(begun); at != std::string::npos; at = log.find(begun, at + 1)) ++found;
      return found;
    };
    if (!wait_until([&] { return begun_count() == count; }, 15s)) {
      ADD_FAILURE() << begun_count() << " of " << count << " sleeps begun\n" << bridge_->log();
      calls.clear();
    }
    return calls;
  }
  // A provider of its own process whose calls may last a minute, offered as rt.Diagnostic0.
  void start_patient_provider() {
    start_manager("m", "labhost",
                  "components:\n  - type: Diagnostic\n    activate: true\n    config: {deadline_ms: 60000}\n");
  }

  // How many connections the provider's port holds with a port of the bridge RTC.
  int bridge_connections(RTC::PortService_ptr port) {
    RTC::ConnectorProfileList_var profiles = port->get_connector_profiles();
    int count = 0;
    for (CORBA::ULong i = 0; i < profiles->length(); ++i) {
      if (rtc::nv_string(profiles[i].properties, "urslink.connector")) ++count;
    }
    return count;
  }
  RTC::PortService_ptr provider_port() {
    auto rtc = resolve<RTC::RTObject>(kProviderPath);
    return rtc::find_port(rtc, "diagnostic");
  }

  // Starts a bridge importing diag with its connections kept under <dir>/bridge-data.
  void start_importing_bridge(const std::string& name) {
    bridge_ = launch_bridge(name, kImportRules,
                            {"--server", server_address_, "--naming", naming_->address(), "--host", "bridgehost",
                             "--data-dir", dir_ + "/bridge-data"});
  }
  // True once this process's consumer reaches diag through the bridge.
  bool consumer_echoes(const std::string& text) {
    try {
      URS::Diagnostic_var diag = consumer_->consumer().get<URS::Diagnostic>();
      if (CORBA::is_nil(diag)) return false;
      CORBA::String_var echoed = diag->echo(text.c_str());
      return text == echoed.in();
    } catch (const CORBA::Exception&) {
      return false;
    }
  }

  void TearDown() override {
    if (consumer_) consumer_->exit();
    consumer_.reset();
    BridgeSpaceTest::TearDown();
  }

  std::unique_ptr<DiagnosticConsumer> consumer_;
};

TEST_F(BridgeInterop, ACallWithoutDeadlineGetsTheRulesDeadlineAboveTheOldClientDefault) {
  // A provider that takes its time, as an OpenRTM-aist one does (no deadline of its own below 30 s).
  start_manager("m", "labhost",
                "components:\n  - type: Diagnostic\n    activate: true\n    config: {deadline_ms: 30000}\n");
  start_bridge(diagnostic_rules(25000));
  ASSERT_TRUE(wait_for_service("rt.Diagnostic0")) << bridge_->log();
  // 10.5 s: more than the 10 s a client used to put on the wire when given no deadline.
  const auto r = urs({"call", "rt.Diagnostic0", "sleep", R"({"ms":10500})"}, 60s);
  EXPECT_EQ(r.exit_code, 0) << r.out << r.err;
}

// Six slow calls in flight to one provider process, one more than omniORB's default number of
// connections to a peer: a seventh, fast call is answered while all six still run.
TEST_F(BridgeInterop, SixSlowCallsToOneProviderHoldUpNoOther) {
  start_patient_provider();
  start_bridge(diagnostic_rules(60000));
  ASSERT_TRUE(wait_for_service("rt.Diagnostic0")) << bridge_->log();
  const auto slow = sleeping(6, 20000);
  ASSERT_EQ(slow.size(), 6u);
  const auto r = echo("rt.Diagnostic0");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  for (const auto& call : slow) EXPECT_TRUE(call->running()) << "a 20 s sleep returned before the echo did";
}

// A bridge sending at most 2 calls at once to one process (--max-calls-per-peer 2), and two
// providers in that process: rt.Diagnostic0, whose rule allows a minute, and rt.Diagnostic1,
// whose rule bounds every call at 1 s. With two slow calls in flight to the first, a call to the
// second waits for one of them, is never sent when its 1 s passes first, and says why; given
// time, a call waits and is sent once one returns.
TEST_F(BridgeInterop, ACallBeyondTheCallsPerPeerWaitsWithinItsDeadline) {
  start_manager("m", "labhost",
                "components:\n"
                "  - {type: Diagnostic, instance: Diagnostic0, activate: true, config: {deadline_ms: 60000}}\n"
                "  - {type: Diagnostic, instance: Diagnostic1, activate: true}\n");
  bridge_ = launch_bridge("bridge",
                          "name: bridge-test\n"
                          "rt_to_camus:\n"
                          "  poll_ms: 100\n"
                          "  providers:\n"
                          "    - {match: \"*/Diagnostic0.rtc\", name: \"rt.{instance}\", deadline_ms: 60000}\n"
                          "    - {match: \"*/Diagnostic1.rtc\", name: \"rt.{instance}\", deadline_ms: 1000}\n",
                          {"--server", server_address_, "--naming", naming_->address(), "--host", "bridgehost",
                           "--max-calls-per-peer", "2"});
  ASSERT_TRUE(wait_for_service("rt.Diagnostic0")) << bridge_->log();
  ASSERT_TRUE(wait_for_service("rt.Diagnostic1")) << bridge_->log();
  const auto slow = sleeping(2, 8000);
  ASSERT_EQ(slow.size(), 2u);
  const auto waited = urs({"call", "--deadline-ms", "30000", "rt.Diagnostic1", "echo", R"({"text":"hi"})"});
  EXPECT_NE(waited.exit_code, 0);
  EXPECT_NE(waited.err.find("DEADLINE_EXCEEDED: deadline passed before echo was sent"), std::string::npos)
      << waited.err;
  EXPECT_NE(waited.err.find("2 calls to it at most (max_calls_per_peer)"), std::string::npos) << waited.err;
  for (const auto& call : slow) EXPECT_TRUE(call->running()) << "a sleep returned before the echo gave up";

  const auto queued = urs({"call", "--deadline-ms", "30000", "rt.Diagnostic0", "echo", R"({"text":"hi"})"}, 40s);
  EXPECT_EQ(queued.exit_code, 0) << queued.err;
}

TEST_F(BridgeInterop, APausedProviderIsSlowNotGoneAndServesAgain) {
  start_manager("m", "labhost", "components:\n  - type: Diagnostic\n    activate: true\n");
  start_bridge(diagnostic_rules(1500));
  ASSERT_TRUE(wait_for_service("rt.Diagnostic0")) << bridge_->log();
  ASSERT_EQ(echo("rt.Diagnostic0").exit_code, 0);

  manager("m").signal(SIGSTOP);
  const auto paused = Clock::now();
  EXPECT_TRUE(wait_state("rt.Diagnostic0", "slow")) << bridge_->log();
  // Paused for 3 s in all, as when it was withdrawn for good: it stays offered.
  std::this_thread::sleep_for(3s - (Clock::now() - paused));
  EXPECT_EQ(state_of("rt.Diagnostic0"), "slow");
  manager("m").signal(SIGCONT);

  EXPECT_TRUE(wait_state("rt.Diagnostic0", "available")) << bridge_->log();
  const auto r = echo("rt.Diagnostic0");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  RTC::PortService_var port = provider_port();
  EXPECT_EQ(bridge_connections(port), 1) << "one connection, not a stale one besides";
}

TEST_F(BridgeInterop, ADroppedConnectionIsDroppedOnBothEndsSoItIsMadeAgain) {
  start_manager("m", "labhost", "components:\n  - type: Diagnostic\n    activate: true\n");
  start_bridge(diagnostic_rules(1500));
  ASSERT_TRUE(wait_for_service("rt.Diagnostic0")) << bridge_->log();
  RTC::PortService_var port = provider_port();
  ASSERT_EQ(bridge_connections(port), 1);
  CORBA::Object_var provider = client_->resolve(kProviderPath);

  // Its binding goes away: the bridge drops the connection, and the provider's half with it.
  ASSERT_TRUE(client_->unbind(kProviderPath));
  ASSERT_TRUE(wait_service_gone("rt.Diagnostic0")) << bridge_->log();
  EXPECT_TRUE(wait_until([&] { return bridge_connections(port) == 0; }, 5s))
      << "the provider still holds its half of the dropped connection";

  // A half the bridge could not take back (the provider was unreachable then): the port refuses
  // a new connection to the bridge while it holds it, so the bridge drops it before connecting.
  RTC::ConnectorProfile stale;
  stale.name = CORBA::string_dup("urs-bridge.bridge-test");
  stale.connector_id = CORBA::string_dup("stale-half");
  auto bridge_rtc = resolve<RTC::RTObject>("bridgehost.host_cxt/Bridge0.rtc");
  RTC::PortService_var providers = rtc::find_port(bridge_rtc, "providers");
  stale.ports.length(2);
  stale.ports[0] = RTC::PortService::_duplicate(providers);
  stale.ports[1] = RTC::PortService::_duplicate(port);
  rtc::nv_set(stale.properties, "urslink.connector", "bridge-test");
  ASSERT_EQ(port->notify_connect(stale), RTC::RTC_OK);  // the provider's half only
  ASSERT_EQ(bridge_connections(port), 1);

  client_->rebind(kProviderPath, provider);
  ASSERT_TRUE(wait_for_service("rt.Diagnostic0")) << bridge_->log();
  const auto r = echo("rt.Diagnostic0");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  RTC::ConnectorProfileList_var profiles = port->get_connector_profiles();
  ASSERT_EQ(profiles->length(), 1u);
  EXPECT_STRNE(profiles[0].connector_id.in(), "stale-half");
}

TEST_F(BridgeInterop, AnInactiveProviderIsListedAsSuchAndCallsSayHowToActivateIt) {
  // Created Inactive, with OpenRTM-aist's CorbaPort behaviour: its provided object does not
  // exist until the component is activated (the IOR it published stays the same).
  start_manager("m", "labhost", "components:\n  - type: Diagnostic\n    serve_while_inactive: false\n");
  CORBA::Object_var object = provided_object(kProviderPath, "diagnostic", "URS::Diagnostic", "diagnostic");
  ASSERT_FALSE(CORBA::is_nil(object));
  EXPECT_TRUE(object->_non_existent());

  start_bridge(diagnostic_rules(1500));
  ASSERT_TRUE(wait_for_service("rt.Diagnostic0")) << bridge_->log();
  EXPECT_TRUE(wait_state("rt.Diagnostic0", "inactive")) << listed("rt.Diagnostic0") << "\n" << bridge_->log();
  auto r = echo("rt.Diagnostic0");
  EXPECT_EQ(r.exit_code, 3) << r.err;  // UNAVAILABLE
  EXPECT_NE(r.err.find(std::string("UNAVAILABLE: echo: provider component ") + kProviderPath +
                       " is INACTIVE; activate it with `urs rtc act " + kProviderPath + "`"),
            std::string::npos)
      << r.err;

  // The advice works.
  r = run_command({URS_CLI_BIN, "rtc", "--naming", naming_->address(), "act", kProviderPath});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(wait_state("rt.Diagnostic0", "available")) << bridge_->log();
  r = echo("rt.Diagnostic0");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_FALSE(object->_non_existent());
}

TEST_F(BridgeInterop, BoundedReferencesKeepTheirOwnTimeouts) {
  start_manager("m", "labhost", "components:\n  - type: Diagnostic\n    activate: true\n");
  CORBA::Object_var object = provided_object(kProviderPath, "diagnostic", "URS::Diagnostic", "diagnostic");
  ASSERT_FALSE(CORBA::is_nil(object));
  // As the bridge makes them: a short bound for probes, then a longer one for other calls.
  CORBA::Object_var probe = test_orb().bounded<CORBA::Object>(object, 300ms);
  CORBA::Object_var slow = test_orb().bounded<CORBA::Object>(object, 5000ms);
  auto sleep = [](CORBA::Object_ptr target, CORBA::ULong ms) {
    CORBA::Request_var request = target->_request("sleep");
    request->add_in_arg("ms") <<= ms;
    request->set_return_type(CORBA::_tc_void);
    request->invoke();
    if (CORBA::Exception* raised = request->env()->exception()) raised->_raise();
  };
  try {
    sleep(probe, 1500);
    ADD_FAILURE() << "a call through the 300 ms reference waited for a 1500 ms sleep";
  } catch (const CORBA::TIMEOUT&) {  // omniORB's client call timeout (TRANSIENT_CallTimedout before 4.3)
  } catch (const CORBA::TRANSIENT& e) {
    EXPECT_STREQ(e.NP_minorString(), "TRANSIENT_CallTimedout");
  } catch (const CORBA::Exception& e) {
    ADD_FAILURE() << rtc::describe(e);
  }
  try {
    sleep(slow, 1500);
  } catch (const CORBA::Exception& e) {
    ADD_FAILURE() << "through the 5 s reference: " << rtc::describe(e);
  }
}

TEST_F(BridgeInterop, ARestartedBridgeConnectsItsRtcsConsumersAgain) {
  start_importing_bridge("bridge");
  ASSERT_TRUE(wait_until([&] { return bound(kImportPath); }, 15s)) << bridge_->log();
  // An RT consumer connected to the RTC standing for diag by a tool (no Connector rule).
  consumer_ = std::make_unique<DiagnosticConsumer>("Consumer", "diagnostic");
  consumer_->setup(test_orb(), "Consumer0", 10);
  ASSERT_EQ(consumer_->initialize(), RTC::RTC_OK);
  RTC::PortService_var ours = consumer_->port();
  {
    auto rtc = resolve<RTC::RTObject>(kImportPath);
    RTC::PortService_var provider = rtc::find_port(rtc, "diagnostic");
    ASSERT_EQ(rtc::connect_ports({ours.in(), provider.in()}, "Consumer0.diagnostic_camus_diag.diagnostic").code,
              RTC::RTC_OK);
  }
  ASSERT_TRUE(consumer_echoes("before"));
  RTC::ConnectorProfileList_var before = ours->get_connector_profiles();
  ASSERT_EQ(before->length(), 1u);
  const std::string id = before[0].connector_id.in();
  const std::string kept = dir_ + "/bridge-data/connections-bridge-test.yaml";
  ASSERT_TRUE(wait_until([&] { return read_text(kept).find(id) != std::string::npos; }, 10s)) << bridge_->log();

  // Killed: the consumer keeps a connection to ports that are gone; the next bridge makes it anew.
  bridge_->kill9();
  EXPECT_FALSE(consumer_echoes("while away"));
  start_importing_bridge("bridge2");
  EXPECT_TRUE(wait_until([&] { return consumer_echoes("after a kill"); }, 20s)) << bridge_->log();
  RTC::ConnectorProfileList_var after = ours->get_connector_profiles();
  ASSERT_EQ(after->length(), 1u) << "the stale connection is left besides the new one";
  EXPECT_EQ(std::string(after[0].connector_id.in()), id);

  // Stopped cleanly: it disconnects its RTCs' consumers on the way out, and connects them again.
  bridge_->signal(SIGTERM);
  EXPECT_EQ(bridge_->wait(15s), 0);
  EXPECT_FALSE(consumer_->consumer().connected());
  start_importing_bridge("bridge3");
  EXPECT_TRUE(wait_until([&] { return consumer_echoes("after a stop"); }, 20s)) << bridge_->log();

  // Deactivated (its RTCs withdrawn, the consumer disconnected), then activated again.
  auto bridge_rtc = resolve<RTC::RTObject>("bridgehost.host_cxt/Bridge0.rtc");
  RTC::ExecutionContextList_var contexts = bridge_rtc->get_owned_contexts();
  ASSERT_EQ(contexts->length(), 1u);
  ASSERT_EQ(contexts[0]->deactivate_component(bridge_rtc), RTC::RTC_OK);
  EXPECT_TRUE(wait_until([&] { return !consumer_->consumer().connected(); }, 10s)) << bridge_->log();
  ASSERT_EQ(contexts[0]->activate_component(bridge_rtc), RTC::RTC_OK);
  EXPECT_TRUE(wait_until([&] { return consumer_echoes("after a reactivation"); }, 20s)) << bridge_->log();
}

TEST_F(BridgeInterop, ReferencesCarryTheirRepositoryIdAndAnAddressTheNamingServicesPeersReach) {
  start_manager("m", "labhost", "components:\n  - type: Diagnostic\n    activate: true\n");
  start_bridge(kImportRules);  // no --listen
  ASSERT_TRUE(wait_until([&] { return bound(kImportPath); }, 15s)) << bridge_->log();
  // omniNames listens on loopback: so must what its clients are given.
  const auto expect_reachable = [&](const Catior& seen, const std::string& what) {
    EXPECT_EQ(seen.host, "127.0.0.1") << what;
    EXPECT_TRUE(accepts_tcp(seen.port)) << what << " port " << seen.port;
  };
  for (const std::string& path : {std::string("bridgehost.host_cxt/Bridge0.rtc"), std::string(kImportPath)}) {
    CORBA::Object_var rtc = client_->resolve(path);
    const Catior seen = catior(test_orb().object_to_string(rtc));
    EXPECT_EQ(seen.type_id, "IDL:openrtm.aist.go.jp/OpenRTM/DataFlowComponent:1.0") << path;
    expect_reachable(seen, path);
  }
  // What the RTC standing for diag provides, and what the manager's hosted agent provides:
  // DSI servants, which know their type only at run time.
  for (const std::string& path : {std::string(kImportPath), std::string(kProviderPath)}) {
    CORBA::Object_var provided = provided_object(path, "diagnostic", "URS::Diagnostic", "diagnostic");
    ASSERT_FALSE(CORBA::is_nil(provided)) << path;
    const Catior seen = catior(test_orb().object_to_string(provided));
    EXPECT_EQ(seen.type_id, "IDL:URS/Diagnostic:1.0") << path;
    expect_reachable(seen, path + " provider");
  }
}

}  // namespace
}  // namespace urs::test
