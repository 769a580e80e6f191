// `urs rtc` against real processes: omniNames, urs-rtc-manager hosting Diagnostic,
// DiagnosticCaller, Counter and Sink under testhost.host_cxt, and the urs binary.

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <signal.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <regex>
#include <stdexcept>
#include <string>
#include <vector>

#include "metrics_scrape.hpp"
#include "naming_service.hpp"
#include "process.hpp"
#include "rt_space.hpp"

namespace urs::test {
namespace {

using ::testing::ContainsRegex;
using ::testing::HasSubstr;
using ::testing::Not;
using namespace std::chrono_literals;

class RtcCliTest : public ::testing::Test {
 public:
  CommandResult urs(const std::vector<std::string>& args) {
    std::vector<std::string> argv = {URS_CLI_BIN, "rtc", "--naming", naming_->address()};
    argv.insert(argv.end(), args.begin(), args.end());
    return run_command(argv, 30s);
  }

 protected:
  void SetUp() override {
    dir_ = make_temp_dir("rtc_cli");
    naming_ = std::make_unique<NamingService>(dir_);
    manager_ = start_manager("testhost", {"Diagnostic", "DiagnosticCaller", "Counter", "Sink"});
  }

  void TearDown() override {
    if (HasFailure()) std::cerr << "---- manager log\n" << (manager_ ? manager_->log() : "");
    if (manager_) {
      manager_->signal(SIGTERM);
      manager_->wait(5s);
    }
    manager_.reset();
    naming_.reset();
    std::filesystem::remove_all(dir_);
  }

  // A manager binding one component of each type under "<host>.host_cxt", up once its ready
  // file is written.
  std::unique_ptr<Process> start_manager(const std::string& host, const std::vector<std::string>& types) {
    const std::string config = dir_ + "/" + host + ".yaml";
    const std::string ready = dir_ + "/" + host + ".ready";
    std::ofstream out(config);
    out << "components:\n";
    for (const std::string& type : types) out << "  - type: " << type << "\n";
    out.close();
    auto manager = std::make_unique<Process>(
        std::vector<std::string>{URS_RTC_MANAGER_BIN, "--space", "lab", "--naming", naming_->address(), "--host", host,
                                 "--config", config, "--ready-file", ready, "--log-level", "debug", "--metrics-listen",
                                 "127.0.0.1:0"},
        dir_ + "/" + host + ".log");
    const bool up = wait_until([&] { return std::filesystem::exists(ready) || !manager->running(); }, 20s);
    if (!up || !manager->running()) throw std::runtime_error("urs-rtc-manager did not come up:\n" + manager->log());
    return manager;
  }

  static std::string path(const std::string& instance) { return "testhost.host_cxt/" + instance + ".rtc"; }

  // The state `ls` shows for one component: its line is "PATH  STATE".
  std::string state(const std::string& instance) {
    const CommandResult r = urs({"ls", path(instance)});
    EXPECT_EQ(r.exit_code, 0) << r.err;
    const std::string prefix = path(instance) + "  ";
    if (r.out.rfind(prefix, 0) != 0 || r.out.back() != '\n') return "unexpected: " + r.out;
    return r.out.substr(prefix.size(), r.out.size() - prefix.size() - 1);
  }

  std::string dir_;
  std::unique_ptr<NamingService> naming_;
  std::unique_ptr<Process> manager_;
};

TEST_F(RtcCliTest, LsShowsTheTreeWithComponentStates) {
  CommandResult r = urs({"ls"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("testhost.host_cxt/\n"));
  for (const std::string instance : {"Diagnostic0", "DiagnosticCaller0", "Counter0", "Sink0"}) {
    EXPECT_THAT(r.out, ContainsRegex("\n  " + instance + "\\.rtc +Inactive\n"));
  }

  // A context lists its contents; an object, itself. A leading '/' is accepted.
  r = urs({"ls", "/testhost.host_cxt"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, ContainsRegex("^Counter0\\.rtc +Inactive\n"));
  EXPECT_THAT(r.out, Not(HasSubstr("host_cxt")));
  r = urs({"ls", "/" + path("Diagnostic0")});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.out, path("Diagnostic0") + "  Inactive\n");
}

TEST_F(RtcCliTest, LsLongAddsPortsWithTypeAndConnectionCount) {
  const CommandResult r = urs({"ls", "-l", "testhost.host_cxt"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, ContainsRegex("Diagnostic0\\.rtc +Inactive\n    diagnostic  CorbaPort  0 connections\n"));
  EXPECT_THAT(r.out, ContainsRegex("\n    count +DataOutPort [^\n]*TimedLong[^\n]* 0 connections\n"));
  EXPECT_THAT(r.out, ContainsRegex("\n    pose +DataInPort [^\n]*TimedPose2D[^\n]* 0 connections\n"));
}

TEST_F(RtcCliTest, ActDeactResetFollowTheLifecycle) {
  CommandResult r = urs({"act", path("Diagnostic0")});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.out, "");
  EXPECT_EQ(state("Diagnostic0"), "Active");

  r = urs({"act", path("Diagnostic0")});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(r.err, "urs: rtc act: " + path("Diagnostic0") + ": PRECONDITION_NOT_MET\n");

  r = urs({"deact", path("Diagnostic0")});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(state("Diagnostic0"), "Inactive");

  // Only a component in Error can be reset.
  r = urs({"reset", path("Diagnostic0")});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("PRECONDITION_NOT_MET"));
}

TEST_F(RtcCliTest, ActTriesEveryPathAndReportsEachFailure) {
  const CommandResult r = urs({"act", path("Diagnostic0"), path("Nope0"), path("Counter0")});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(r.err, "urs: rtc act: " + path("Nope0") + ": not bound\n");
  EXPECT_EQ(state("Diagnostic0"), "Active");
  EXPECT_EQ(state("Counter0"), "Active");
}

TEST_F(RtcCliTest, CatShowsProfileContextsPropertiesAndPorts) {
  CommandResult r = urs({"cat", path("Diagnostic0")});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr(path("Diagnostic0") + "  Inactive\n"));
  EXPECT_THAT(r.out, ContainsRegex("\n  instance: +Diagnostic0\n"));
  EXPECT_THAT(r.out, ContainsRegex("\n  type: +Diagnostic\n"));
  EXPECT_THAT(r.out, ContainsRegex("\n  vendor: +URSLink\n"));
  EXPECT_THAT(r.out, ContainsRegex("\n    owned 0: periodic, [0-9.]+ Hz, Inactive\n"));
  EXPECT_THAT(r.out, HasSubstr("urslink.space=lab"));
  EXPECT_THAT(r.out, HasSubstr("  1 port:\n    Diagnostic0.diagnostic  CorbaPort\n"));
  EXPECT_THAT(r.out, ContainsRegex("\n        provided  [^\n]*Diagnostic  diagnostic\n"));
  EXPECT_THAT(r.out, HasSubstr("port.port_type=CorbaPort"));
  EXPECT_THAT(r.out, HasSubstr("  configuration set default (active): no parameters\n"));
  r = urs({"cat", path("DiagnosticCaller0")});
  EXPECT_THAT(r.out, HasSubstr("  configuration set default (active):\n    text=ping\n"));

  // One port, by its short or its full name.
  r = urs({"cat", path("DiagnosticCaller0") + ":diagnostic"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, ContainsRegex("^DiagnosticCaller0\\.diagnostic  CorbaPort\n"));
  EXPECT_THAT(r.out, ContainsRegex("\n    required  [^\n]*Diagnostic  diagnostic\n"));
  EXPECT_THAT(r.out, Not(HasSubstr("instance:")));
  r = urs({"cat", path("Sink0") + ":Sink0.count"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, ContainsRegex("^Sink0\\.count  DataInPort "));
}

TEST_F(RtcCliTest, ConShowsTheConnectionOnBothPortsAndDisRemovesIt) {
  const std::string caller = path("DiagnosticCaller0") + ":diagnostic";
  const std::string provider = path("Diagnostic0") + ":Diagnostic0.diagnostic";
  CommandResult r = urs({"con", caller, provider, "--name", "diag-link", "test.note=hello"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  ASSERT_THAT(r.out, ContainsRegex("^[^\n ]+\n$"));
  const std::string id = r.out.substr(0, r.out.size() - 1);

  for (const std::string& port : {caller, provider}) {
    r = urs({"cat", port});
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_THAT(r.out, HasSubstr("  1 connection:\n    " + id + "  name: diag-link\n"));
    EXPECT_THAT(r.out, HasSubstr("      ports: DiagnosticCaller0.diagnostic, Diagnostic0.diagnostic\n"));
    EXPECT_THAT(r.out, HasSubstr("test.note=hello"));
  }
  r = urs({"ls", "-l", path("Diagnostic0")});
  EXPECT_THAT(r.out, HasSubstr("diagnostic  CorbaPort  1 connection\n"));

  r = urs({"dis", provider, caller});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  for (const std::string& port : {caller, provider}) {
    r = urs({"cat", port});
    EXPECT_THAT(r.out, HasSubstr("  0 connections\n"));
  }
  r = urs({"dis", caller, provider});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("are not connected"));

  // A connector id chosen by the caller is kept; the same id twice is refused.
  r = urs({"con", caller, provider, "--id", "my-link-1"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.out, "my-link-1\n");
  r = urs({"con", caller, provider, "--id", "my-link-1"});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("BAD_PARAMETER"));
}

TEST_F(RtcCliTest, CallIsAConsumerOfAnyProviderPortFromItsInterfaceDescription) {
  const std::string provider = path("Diagnostic0") + ":diagnostic";
  CommandResult r = urs({"call", provider, "echo", R"({"text":"héllo RT"})"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.out, "{\"result\":\"héllo RT\"}\n");
  r = urs({"call", provider, "add", R"({"a":1.5,"b":2})"});
  EXPECT_EQ(r.out, "{\"result\":3.5}\n");
  r = urs({"call", provider, "fail", R"({"reason":"jammed","code":9})"});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("USER_EXCEPTION URS.Failure {\"reason\":\"jammed\",\"code\":9}"));
  r = urs({"call", provider, "sleep", R"({"ms":3000})", "--deadline-ms", "200"});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("DEADLINE_EXCEEDED"));
  r = urs({"call", provider, "explode"});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("has no operation 'explode' (echo, add, sleep, blob, checksum, fail, notify)"));
  r = urs({"call", provider, "echo", R"({"text": 5})"});
  EXPECT_EQ(r.exit_code, 2) << r.out;
  r = urs({"call", path("Counter0") + ":count", "echo"});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("provides no interface"));
  // Calling leaves no connection behind.
  r = urs({"ls", "-l", path("Diagnostic0")});
  EXPECT_THAT(r.out, HasSubstr("diagnostic  CorbaPort  0 connections\n"));
}

// One call followed and counted on the RT side: the trace id `urs rtc call` prints travels in the
// request's service context and is on the manager's line for serving it; the manager's metrics
// count the calls its component served, by instance, operation and status.
TEST_F(RtcCliTest, CallCarriesItsTraceToTheServingComponentWhichCountsIt) {
  const std::string provider = path("Diagnostic0") + ":diagnostic";
  CommandResult r = urs({"call", provider, "echo", R"({"text":"followed"})", "--show-trace"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  std::smatch match;
  ASSERT_TRUE(std::regex_search(r.err, match, std::regex("trace ([0-9a-f]{32})\n"))) << r.err;
  const std::regex served("trace=" + std::string(match[1]) + " served Diagnostic0\\.echo: OK in [0-9]+ us");
  EXPECT_TRUE(wait_until([&] { return std::regex_search(manager_->log(), served); }, 5s));
  r = urs({"call", provider, "echo", R"({"text":"again"})"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  r = urs({"call", provider, "fail", R"({"reason":"jammed","code":9})"});
  ASSERT_EQ(r.exit_code, 1) << r.err;

  const auto port = metrics_port_in_log(manager_->log());
  ASSERT_TRUE(port.has_value());
  const auto response = http_get(*port, "/metrics");
  ASSERT_EQ(response.status, 200);
  auto calls = [&](const std::string& operation, const std::string& status) {
    return metric_value(response.body, "urslink_served_calls_total",
                        {{"via", "corba"}, {"service", "Diagnostic0"}, {"operation", operation}, {"status", status}});
  };
  EXPECT_EQ(calls("echo", "OK"), 2);
  EXPECT_EQ(calls("fail", "USER_EXCEPTION"), 1);
  EXPECT_EQ(metric_sum(response.body, "urslink_served_calls_total"), 3);
  const auto checked = promtool_check_metrics(response.body);
  EXPECT_EQ(checked.out + checked.err, "") << response.body;
  const auto ready = http_get(*port, "/readyz");
  EXPECT_EQ(ready.status, 200);
  EXPECT_EQ(ready.body, "ok components bound\n");
}

TEST_F(RtcCliTest, DataPortsConnectWithTheDefaultPropertiesAndDisAllRemovesThem) {
  CommandResult r = urs({"con", path("Counter0") + ":count", path("Sink0") + ":count"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  r = urs({"con", path("Counter0") + ":count", path("Sink0") + ":pose"});
  EXPECT_EQ(r.exit_code, 1) << "a TimedLong out port connected to a TimedPose2D in port";
  EXPECT_THAT(r.err, HasSubstr(": Counter0.count carries IDL:RTC/TimedLong:1.0 but Sink0.pose carries "
                               "IDL:RTC/TimedPose2D:1.0 (--force connects them anyway)\n"));
  // Forced, the call is made, and the in port itself refuses the data type.
  r = urs({"con", path("Counter0") + ":count", path("Sink0") + ":pose", "--force"});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr(": BAD_PARAMETER\n"));

  r = urs({"cat", path("Sink0") + ":count"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("  1 connection:\n"));
  EXPECT_THAT(r.out, HasSubstr("name: Counter0.count_Sink0.count\n"));
  EXPECT_THAT(r.out, HasSubstr("dataport.interface_type=corba_cdr"));
  EXPECT_THAT(r.out, HasSubstr("dataport.dataflow_type=push"));

  r = urs({"dis", path("Sink0") + ":count", "--all"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  for (const std::string& port : {path("Counter0") + ":count", path("Sink0") + ":count"}) {
    r = urs({"cat", port});
    EXPECT_THAT(r.out, HasSubstr("  0 connections\n"));
  }
}

TEST_F(RtcCliTest, ConRefusesPortsThatCannotWorkTogetherUnlessForced) {
  auto other = start_manager("otherhost", {"DiagnosticCaller"});
  const std::string caller = path("DiagnosticCaller0") + ":diagnostic";
  const std::string second_caller = "otherhost.host_cxt/DiagnosticCaller0.rtc:diagnostic";
  CommandResult r = urs({"con", caller, second_caller});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(r.err,
            "urs: rtc con: DiagnosticCaller0.diagnostic requires URS::Diagnostic but "
            "DiagnosticCaller0.diagnostic provides nothing (--force connects them anyway)\n");
  r = urs({"con", caller, path("Counter0") + ":count"});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("DiagnosticCaller0.diagnostic is a CorbaPort and Counter0.count a DataOutPort"));
  r = urs({"con", path("Counter0") + ":count", path("Counter0") + ":pose"});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("are both DataOutPorts"));
  for (const std::string& port : {caller, path("Counter0") + ":count"}) {
    r = urs({"cat", port});
    EXPECT_THAT(r.out, HasSubstr("  0 connections\n")) << "a refused connection leaves nothing behind";
  }
  // --force connects what the ports themselves accept.
  r = urs({"con", caller, second_caller, "--force"});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  r = urs({"cat", caller});
  EXPECT_THAT(r.out, HasSubstr("  1 connection:\n"));
  other->signal(SIGTERM);
  other->wait(5s);
}

TEST_F(RtcCliTest, ConfListsGetsSetsAndActivatesConfigurationSets) {
  CommandResult r = urs({"conf", "ls", path("Counter0")});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.out, "default (active)  the component's parameters\n  start=0\n  radius=1\n  period=10\n");
  r = urs({"conf", "set", path("Counter0"), "radius", "2.5"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.out, "");
  r = urs({"conf", "get", path("Counter0"), "radius"});
  EXPECT_EQ(r.out, "2.5\n");
  EXPECT_THAT(manager_->log(), HasSubstr("Counter0: configuration parameter radius = 2.5"));

  r = urs({"conf", "set", path("Counter0"), "radius", "wide"});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(r.err,
            "urs: rtc conf set: " + path("Counter0") + ": radius: 'wide' is not a number (set default unchanged)\n");
  r = urs({"conf", "set", path("Counter0"), "start", "5"});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("start is read-only (its value stays '0')"));
  r = urs({"conf", "get", path("Counter0"), "gain"});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err,
              HasSubstr("configuration set default has no parameter 'gain' (parameters: start, radius, period)"));
  r = urs({"conf", "set", path("Counter0"), "radius", "3", "--set", "fast"});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("no configuration set fast"));
  r = urs({"conf", "act", path("Counter0"), "fast"});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("no configuration set 'fast'"));
  r = urs({"conf", "act", path("Counter0"), "default"});
  EXPECT_EQ(r.exit_code, 0) << r.err;

  // A component's behaviour follows: a strict caller with no provider goes to Error when run.
  r = urs({"conf", "set", path("DiagnosticCaller0"), "strict", "true"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  r = urs({"act", path("DiagnosticCaller0")});
  EXPECT_TRUE(wait_until([&] { return state("DiagnosticCaller0") == "Error"; }, 5s));
  r = urs({"conf", "set", path("DiagnosticCaller0"), "strict", "maybe"});
  EXPECT_THAT(r.err, HasSubstr("strict: 'maybe' is not true or false"));
}

// A component that takes every value and keeps another, as an OpenRTM-aist component whose
// parameter cannot parse the text does (DiagnosticCaller's `every` is declared that way): the
// component accepts the call, and `conf set` learns from the set read back that the value was
// not taken, and says what was asked and what the component keeps.
TEST_F(RtcCliTest, ConfSetFailsWhenTheComponentKeepsAnotherValueThanTheOneSet) {
  CommandResult r = urs({"conf", "set", path("DiagnosticCaller0"), "every", "3"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(urs({"conf", "get", path("DiagnosticCaller0"), "every"}).out, "3\n");

  r = urs({"conf", "set", path("DiagnosticCaller0"), "every", "often"});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(r.out, "");
  EXPECT_EQ(r.err, "urs: rtc conf set: " + path("DiagnosticCaller0") +
                       ": parameter 'every' was set to 'often' but the component keeps '3': it refused the value\n");
  EXPECT_EQ(urs({"conf", "get", path("DiagnosticCaller0"), "every"}).out, "3\n");
  EXPECT_THAT(manager_->log(),
              HasSubstr("DiagnosticCaller0: configuration parameter every: 'often' not taken ('often' is not a "
                        "number); it keeps '3'"));

  r = urs({"conf", "set", path("DiagnosticCaller0"), "every", "2.5"});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("parameter 'every' was set to '2.5' but the component keeps '3'"));
}

TEST_F(RtcCliTest, LsLongShowsAComponentWhosePeerIsPausedAsAlive) {
  // A component's port asks its peers whether they still exist when its profile is read; a peer
  // that does not answer (paused) must not make the component itself look unreachable.
  auto paused = start_manager("pausedhost", {"Sink"});
  CommandResult r = urs({"con", path("Counter0") + ":count", "pausedhost.host_cxt/Sink0.rtc:count"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  paused->signal(SIGSTOP);
  r = urs({"ls", "-l", "testhost.host_cxt"});
  const CommandResult cat = urs({"cat", path("Counter0") + ":count"});
  paused->signal(SIGCONT);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, ContainsRegex("^Counter0\\.rtc +Inactive\n    count +DataOutPort [^\n]* 1 connection\n"));
  EXPECT_THAT(r.out, Not(HasSubstr("unreachable")));
  EXPECT_EQ(cat.exit_code, 0) << cat.err;
  EXPECT_THAT(cat.out, HasSubstr("  1 connection:\n"));  // slowness is not death: the connection stays
  paused->signal(SIGTERM);
  paused->wait(5s);
}

// A port that cannot give its profile, as an OpenRTM-aist port does when the check of a dead
// peer fails inside it: the system exception of its own call reaches its caller.
class BrokenPort : public rtc::CorbaPort {
 public:
  BrokenPort() : CorbaPort("broken") {}
  RTC::PortProfile* get_port_profile() override { throw CORBA::TRANSIENT(0, CORBA::COMPLETED_NO); }
};

class ForeignComponent : public rtc::Component {
 public:
  ForeignComponent() : Component({"Foreign", "a component one of whose ports fails", "1.0", "Other", "Test"}) {}

 protected:
  RTC::ReturnCode_t handle_initialize() override {
    add_port(port_);
    return RTC::RTC_OK;
  }

 private:
  BrokenPort port_;
};

TEST_F(RtcCliTest, AComponentWhosePortFailsIsShownAliveWithThePortsError) {
  ForeignComponent foreign;
  foreign.setup(test_orb(), "Foreign0", 10);
  ASSERT_EQ(foreign.initialize(), RTC::RTC_OK);
  rtc::NamingClient naming(test_orb(), naming_->address());
  RTC::RTObject_var reference = foreign.reference();
  naming.bind("foreignhost.host_cxt/Foreign0.rtc", reference);

  CommandResult r = urs({"ls", "-l", "foreignhost.host_cxt"});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.out, "Foreign0.rtc  Inactive\n    port 0  -  no profile: reported an error (TRANSIENT)\n");
  r = urs({"ls", "foreignhost.host_cxt"});
  EXPECT_EQ(r.out, "Foreign0.rtc  Inactive\n");
  // The profile holds the ports' profiles: the component answers, with an error.
  r = urs({"cat", "foreignhost.host_cxt/Foreign0.rtc"});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(r.err, "urs: rtc cat: foreignhost.host_cxt/Foreign0.rtc: reported an error (TRANSIENT)\n");

  naming.unbind("foreignhost.host_cxt/Foreign0.rtc");
  foreign.exit();
}

TEST_F(RtcCliTest, StaleBindingIsShownUnreachableWithoutFailingTheListing) {
  auto gone = start_manager("gonehost", {"Diagnostic"});
  gone->kill9();

  for (const std::vector<std::string>& args : {std::vector<std::string>{"ls"}, {"ls", "-l"}}) {
    const CommandResult r = urs(args);
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_EQ(r.err, "");
    EXPECT_THAT(r.out, HasSubstr("gonehost.host_cxt/\n  Diagnostic0.rtc  unreachable\n"));
    EXPECT_THAT(r.out, ContainsRegex("testhost.host_cxt/\n  Counter0\\.rtc +Inactive\n"));
  }
  const std::string stale = "gonehost.host_cxt/Diagnostic0.rtc";
  CommandResult r = urs({"act", stale});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr(stale + ": unreachable ("));
  r = urs({"cat", stale});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr(stale + ": unreachable ("));
}

TEST_F(RtcCliTest, HungComponentIsShownUnreachableWithinTheCallTimeout) {
  auto hung = start_manager("hunghost", {"Diagnostic"});
  hung->signal(SIGSTOP);
  // Without the call timeout `urs ls` would wait for the stopped process for ever (and be killed
  // by run_command's bound, failing the exit code below).
  const CommandResult r = urs({"ls", "--call-timeout-ms", "500"});
  hung->signal(SIGCONT);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("hunghost.host_cxt/\n  Diagnostic0.rtc  unreachable\n"));
  EXPECT_THAT(r.out, ContainsRegex("testhost.host_cxt/\n  Counter0\\.rtc +Inactive\n"));
}

TEST_F(RtcCliTest, UnknownPathsAndPortsFailWithAPreciseMessage) {
  CommandResult r = urs({"cat", path("Nope0")});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(r.err, "urs: rtc cat: " + path("Nope0") + ": not bound\n");

  r = urs({"ls", "nohost.host_cxt"});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(r.err, "urs: rtc ls: nohost.host_cxt: not bound\n");

  r = urs({"cat", path("Diagnostic0") + ":nosuch"});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(r.err, "urs: rtc cat: " + path("Diagnostic0") + ": no port 'nosuch' (ports: diagnostic)\n");

  r = urs({"con", path("Counter0") + ":count", path("Sink0") + ":nosuch"});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("no port 'nosuch' (ports: "));
}

void expect_usage_errors(RtcCliTest& test, const std::vector<std::vector<std::string>>& cases) {
  for (const auto& args : cases) {
    const CommandResult r = test.urs(args);
    EXPECT_EQ(r.exit_code, 2) << ::testing::PrintToString(args) << "\n" << r.err;
    EXPECT_FALSE(r.err.empty()) << ::testing::PrintToString(args);
  }
}

TEST_F(RtcCliTest, BadArgumentsExitWithTwo) {
  expect_usage_errors(*this, {
                                 {"con", path("Counter0") + ":count", path("Sink0") + ":count", "no-equals-sign"},
                                 {"con", path("Counter0"), path("Sink0") + ":count"},
                                 {"dis", path("Counter0") + ":count"},
                                 {"dis", path("Counter0") + ":count", path("Sink0") + ":count", "--all"},
                                 {"cat", "testhost.host_cxt//Diagnostic0.rtc"},
                                 {"cat", path("Diagnostic0") + ":"},
                             });
  const CommandResult r = run_command({URS_CLI_BIN, "rtc", "--naming", "no-port-here", "ls"}, 30s);
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_THAT(r.err, HasSubstr("--naming"));
}

TEST_F(RtcCliTest, CommandLineParseErrorsExitWithTwo) {
  expect_usage_errors(*this, {
                                 {"con", path("Counter0") + ":count"},
                                 {"act"},
                                 {"frobnicate"},
                                 {"ls", "--no-such-flag"},
                             });
}

TEST_F(RtcCliTest, UnreachableNamingServiceExitsWithThreeAndOneLine) {
  const std::string nowhere = "127.0.0.1:" + std::to_string(free_tcp_port());
  for (const std::vector<std::string>& args :
       {std::vector<std::string>{"ls"}, {"cat", path("Diagnostic0")}, {"act", path("Diagnostic0")}}) {
    std::vector<std::string> argv = {URS_CLI_BIN, "rtc", "--naming", nowhere};
    argv.insert(argv.end(), args.begin(), args.end());
    const CommandResult r = run_command(argv, 30s);
    EXPECT_EQ(r.exit_code, 3) << r.err;
    EXPECT_THAT(r.err, HasSubstr("naming service " + nowhere + " unreachable"));
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  }
}

TEST_F(RtcCliTest, TheManagersNamingContextComesFromTheEnvironment) {
  // As compose names each service's context for people instead of by container id; replicas of
  // one service share the context and still get names of their own.
  std::vector<std::unique_ptr<Process>> replicas;
  for (const std::string replica : {"a", "b"}) {
    const std::string ready = dir_ + "/" + replica + ".ready";
    replicas.push_back(std::make_unique<Process>(
        std::vector<std::string>{"/usr/bin/env", "URS_HOST_CONTEXT=jp-devices", URS_RTC_MANAGER_BIN, "--space", "lab",
                                 "--naming", naming_->address(), "--config", dir_ + "/testhost.yaml", "--ready-file",
                                 ready},
        dir_ + "/" + replica + ".log"));
    ASSERT_TRUE(wait_until([&] { return std::filesystem::exists(ready) || !replicas.back()->running(); }, 20s))
        << replicas.back()->log();
  }
  const CommandResult r = urs({"ls", "jp-devices.host_cxt"});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, ContainsRegex("^Counter0\\.rtc +Inactive\nCounter1\\.rtc +Inactive\n"));
  for (auto& replica : replicas) {
    replica->signal(SIGTERM);
    replica->wait(5s);
  }
}

TEST_F(RtcCliTest, NamingAddressComesFromTheEnvironmentToo) {
  const CommandResult r =
      run_command({"/usr/bin/env", "URS_NAMING=" + naming_->address(), URS_CLI_BIN, "rtc", "ls"}, 30s);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, ContainsRegex("Diagnostic0\\.rtc +Inactive"));
}

}  // namespace
}  // namespace urs::test
