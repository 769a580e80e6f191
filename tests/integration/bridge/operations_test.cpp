// Operating two linked spaces (docs/operations.md, "Monitoring"): "kr", a CAMUS space
// (urs-camus-server, urs-sam, urs-bridge with no naming service), and "jp", an RT-Middleware space
// (omniNames, urs-rtc-manager with a Diagnostic RTC, urs-bridge with no CAMUS server), linked over
// DDS (UDP only), each bridge with --metrics-listen. What Prometheus scrapes from each bridge after
// cross-space calls (the calls of each direction, those served for the other space, the link per
// remote space), clean for promtool; their readiness; and one call followed by its trace id
// through the client, both bridges, jp's audit log and the component that served it.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iostream>
#include <regex>

#include "bridge_fixture.hpp"
#include "dds_domain.hpp"
#include "metrics_scrape.hpp"

namespace urs::test {
namespace {

using namespace std::chrono_literals;
using ::testing::HasSubstr;

constexpr auto kLease = 1500ms;

class BridgeOperations : public BridgeSpaceTest {
 protected:
  void SetUp() override {
    space_ = "kr";
    BridgeSpaceTest::SetUp();
    if (HasFatalFailure()) return;
    start_manager("m", "jphost", "components:\n  - type: Diagnostic\n");
    // jp's RT providers offered to the other spaces as rt.<instance>, each call audited.
    jp_ = launch_bridge("bridge-jp",
                        "name: bridge-jp\nrt_to_camus: {poll_ms: 100, providers: [{match: \"*\", name: "
                        "\"rt.{instance}\"}]}\n" +
                            dds() + "  audit: {file: \"" + dir_ + "/jp-audit.jsonl\"}\n",
                        {"--naming", naming_->address(), "--host", "jphost", "--metrics-listen", "127.0.0.1:0"}, "jp");
    kr_ = launch_bridge("bridge-kr", "name: bridge-kr\n" + dds() + "  import: {as_rtc: \"\"}\n",
                        {"--server", server_address_, "--metrics-listen", "127.0.0.1:0"});
    ASSERT_TRUE(jp_ && kr_);
    jp_metrics_ = metrics_port(*jp_);
    kr_metrics_ = metrics_port(*kr_);
    ASSERT_TRUE(wait_for_service("jp/rt.Diagnostic0", 20s)) << kr_->log() << jp_->log();
  }

  void TearDown() override {
    const std::pair<const char*, std::unique_ptr<Process>*> bridges[] = {{"bridge-jp", &jp_}, {"bridge-kr", &kr_}};
    for (const auto& [name, bridge] : bridges) {
      if (HasFailure() && *bridge) std::cerr << "---- " << name << " log\n" << (*bridge)->log();
      bridge->reset();
    }
    BridgeSpaceTest::TearDown();
  }

  std::string dds() const {
    return "dds:\n  domain: " + std::to_string(domains_[0]) + "\n  lease_ms: " + std::to_string(kLease.count()) +
           "\n  udp_only: true\n";
  }

  static uint16_t metrics_port(const Process& bridge) {
    EXPECT_TRUE(wait_until([&] { return metrics_port_in_log(bridge.log()).has_value(); }, 10s)) << bridge.log();
    return metrics_port_in_log(bridge.log()).value_or(0);
  }

  static std::string scrape(uint16_t port) {
    const HttpResponse response = http_get(port, "/metrics");
    EXPECT_EQ(response.status, 200) << response.head;
    return response.body;
  }

  // `urs call jp/rt.Diagnostic0 echo` from kr: its trace id (from --show-trace).
  std::string echo_across(const std::string& text) {
    const CommandResult r = urs({"call", "jp/rt.Diagnostic0", "echo", "{\"text\":\"" + text + "\"}", "--show-trace"});
    EXPECT_EQ(r.exit_code, 0) << r.out << r.err;
    EXPECT_THAT(r.out, HasSubstr(text));
    std::smatch match;
    if (!std::regex_search(r.err, match, std::regex("trace ([0-9a-f]{32})\n"))) {
      ADD_FAILURE() << "no trace id in: " << r.err;
      return "";
    }
    return match[1];
  }

  const DdsDomains domains_{1};
  std::unique_ptr<Process> jp_;
  std::unique_ptr<Process> kr_;
  uint16_t jp_metrics_ = 0;
  uint16_t kr_metrics_ = 0;
};

TEST_F(BridgeOperations, EachHopOfACrossSpaceCallIsCountedAndTheLinkIsSeenPerSpace) {
  const std::string kr_before = scrape(kr_metrics_);
  const std::string jp_before = scrape(jp_metrics_);
  constexpr int kCalls = 3;
  for (int i = 0; i < kCalls; ++i) ASSERT_FALSE(echo_across("counted " + std::to_string(i)).empty());

  // kr: its CAMUS side's stand-in of jp's service took the calls and handed them to the link.
  const std::map<std::string, std::string> kr_call{
      {"direction", "dds->camus"}, {"service", "jp/rt.Diagnostic0"}, {"operation", "echo"}};
  auto kr_ok = kr_call;
  kr_ok["status"] = "OK";
  std::string kr_after;
  ASSERT_TRUE(wait_until(
      [&] {
        kr_after = scrape(kr_metrics_);
        return metric_sum(kr_after, "urslink_bridge_calls_total", kr_ok) -
                   metric_sum(kr_before, "urslink_bridge_calls_total", kr_ok) ==
               kCalls;
      },
      5s))
      << kr_after;
  EXPECT_EQ(metric_sum(kr_after, "urslink_bridge_call_duration_seconds_count", kr_call) -
                metric_sum(kr_before, "urslink_bridge_call_duration_seconds_count", kr_call),
            kCalls);
  // jp: the calls kr made were served for it over DDS, and its DDS side's stand-in of the RT
  // provider handed them to the RT side.
  const std::string jp_after = scrape(jp_metrics_);
  const std::map<std::string, std::string> served{
      {"via", "dds"}, {"service", "rt.Diagnostic0"}, {"operation", "echo"}, {"status", "OK"}};
  EXPECT_EQ(metric_sum(jp_after, "urslink_served_calls_total", served) -
                metric_sum(jp_before, "urslink_served_calls_total", served),
            kCalls)
      << jp_after;
  const std::map<std::string, std::string> jp_ok{
      {"direction", "rt->dds"}, {"service", "rt.Diagnostic0"}, {"operation", "echo"}, {"status", "OK"}};
  EXPECT_EQ(metric_sum(jp_after, "urslink_bridge_calls_total", jp_ok) -
                metric_sum(jp_before, "urslink_bridge_calls_total", jp_ok),
            kCalls);

  // The link, per remote space, as each bridge sees it.
  EXPECT_EQ(metric_value(kr_after, "urslink_bridge_link_up", {{"space", "jp"}}), 1.0) << kr_after;
  EXPECT_GE(metric_value(kr_after, "urslink_bridge_link_participants", {{"space", "jp"}}).value_or(0), 1.0);
  EXPECT_EQ(metric_value(kr_after, "urslink_bridge_link_catalog_entries", {{"space", "jp"}}), 1.0);
  EXPECT_EQ(metric_value(kr_after, "urslink_bridge_side_open", {{"side", "dds"}}), 1.0);
  EXPECT_EQ(metric_value(kr_after, "urslink_bridge_stand_ins", {{"direction", "dds->camus"}}), 1.0);
  EXPECT_EQ(metric_value(jp_after, "urslink_bridge_link_up", {{"space", "kr"}}), 1.0) << jp_after;
  EXPECT_EQ(metric_value(kr_after, "urslink_build_info", {{"program", "urs-bridge"}, {"space", "kr"}}), 1.0);

  for (const std::string& text : {kr_after, jp_after}) {
    const CommandResult checked = promtool_check_metrics(text);
    EXPECT_EQ(checked.exit_code, 0) << checked.out << checked.err;
    EXPECT_EQ(checked.out + checked.err, "");
  }
  for (const uint16_t port : {kr_metrics_, jp_metrics_}) {
    const HttpResponse ready = http_get(port, "/readyz");
    EXPECT_EQ(ready.status, 200) << ready.body;
    EXPECT_THAT(ready.body, HasSubstr("ok side dds"));
  }
  EXPECT_THAT(http_get(kr_metrics_, "/readyz").body, HasSubstr("ok side camus"));
  EXPECT_THAT(http_get(jp_metrics_, "/readyz").body, HasSubstr("ok side rt"));

  // jp's bridge gone: kr sees jp lost once its lease passes.
  jp_.reset();
  std::string lost;
  EXPECT_TRUE(wait_until(
      [&] {
        lost = scrape(kr_metrics_);
        return metric_value(lost, "urslink_bridge_link_up", {{"space", "jp"}}) == 0.0;
      },
      15s))
      << lost;
  EXPECT_EQ(metric_value(lost, "urslink_bridge_link_catalog_entries", {{"space", "jp"}}), 0.0);
}

// The link per remote space, as kr's bridge meets it in its calls to jp: each reply a round trip;
// a call past its deadline and calls to jp once its bridge is gone are the link's failures, by
// status, with the time of the last one.
TEST_F(BridgeOperations, TheRoundTripsAndFailuresOfTheCallsToEachSpaceAreCounted) {
  const std::string before = scrape(kr_metrics_);
  const std::string jp_before = scrape(jp_metrics_);
  const std::map<std::string, std::string> jp{{"space", "jp"}};
  constexpr int kCalls = 3;
  for (int i = 0; i < kCalls; ++i) ASSERT_FALSE(echo_across("round trip " + std::to_string(i)).empty());
  std::string after = scrape(kr_metrics_);
  EXPECT_EQ(metric_sum(after, "urslink_bridge_link_round_trips_total", jp) -
                metric_sum(before, "urslink_bridge_link_round_trips_total", jp),
            kCalls)
      << after;
  EXPECT_GT(metric_sum(after, "urslink_bridge_link_round_trip_seconds_total", jp) -
                metric_sum(before, "urslink_bridge_link_round_trip_seconds_total", jp),
            0.0);
  EXPECT_GT(metric_value(after, "urslink_bridge_link_last_round_trip_seconds", jp).value_or(0), 0.0);
  EXPECT_EQ(metric_value(after, "urslink_bridge_link_last_failure_timestamp_seconds", jp), 0.0) << after;
  EXPECT_EQ(metric_sum(after, "urslink_bridge_link_call_failures_total", jp), 0.0);
  EXPECT_GT(metric_value(after, "urslink_bridge_link_reached_since_timestamp_seconds", jp).value_or(0), 0.0) << after;
  // The call payloads both ways: each echo request and reply "round trip N" is 14 bytes (a tag, a
  // length, 12 characters), sent by kr and received by jp, and back.
  auto bytes = [](const std::string& scraped, const std::string& space, const char* direction) {
    return metric_sum(scraped, "urslink_bridge_link_payload_bytes_total", {{"space", space}, {"direction", direction}});
  };
  const std::string jp_after = scrape(jp_metrics_);
  EXPECT_EQ(bytes(after, "jp", "sent") - bytes(before, "jp", "sent"), kCalls * 14) << after;
  EXPECT_EQ(bytes(after, "jp", "received") - bytes(before, "jp", "received"), kCalls * 14) << after;
  EXPECT_EQ(bytes(jp_after, "kr", "received") - bytes(jp_before, "kr", "received"), kCalls * 14) << jp_after;
  EXPECT_EQ(bytes(jp_after, "kr", "sent") - bytes(jp_before, "kr", "sent"), kCalls * 14) << jp_after;
  // `urs link` shows the same, read from that endpoint: jp up, its round trips, no failure.
  const std::string kr_link = "127.0.0.1:" + std::to_string(kr_metrics_);
  CommandResult shown = urs({"link", kr_link});
  ASSERT_EQ(shown.exit_code, 0) << shown.err;
  std::cout << "urs link " << kr_link << ":\n" << shown.out;
  EXPECT_THAT(shown.out, ::testing::ContainsRegex("\njp +up [0-9]+[smh] +[1-9][0-9]* +[1-9][0-9]* +[0-9]+ +[0-9.]+ms "
                                                  "+[0-9.]+ms +[1-9][0-9.]*[KMG]?i?B +[1-9][0-9.]*[KMG]?i?B +none\n"))
      << shown.out;

  // A sleep longer than its deadline: the link gives up on it (jp answers too late).
  const auto start = std::chrono::system_clock::now();
  const CommandResult late = urs({"call", "--deadline-ms", "500", "jp/rt.Diagnostic0", "sleep", "{\"ms\":3000}"});
  EXPECT_NE(late.exit_code, 0) << late.out;
  const std::map<std::string, std::string> jp_late{{"space", "jp"}, {"status", "DEADLINE_EXCEEDED"}};
  EXPECT_TRUE(wait_until(
      [&] {
        after = scrape(kr_metrics_);
        return metric_value(after, "urslink_bridge_link_call_failures_total", jp_late) == 1.0;
      },
      5s))
      << after;
  const double since_epoch = std::chrono::duration<double>(start.time_since_epoch()).count();
  EXPECT_GE(metric_value(after, "urslink_bridge_link_last_failure_timestamp_seconds", jp).value_or(0), since_epoch);
  shown = urs({"link", kr_link});
  EXPECT_THAT(shown.out, HasSubstr("1 (DEADLINE_EXCEEDED 1), last ")) << shown.out;

  // jp's bridge gone: kr refuses calls to it (unreachable), each a failure of the link.
  jp_.reset();
  ASSERT_TRUE(wait_until(
      [&] {
        return metric_value(scrape(kr_metrics_), "urslink_bridge_link_up", {{"space", "jp"}}) == 0.0;
      },
      15s));
  const CommandResult refused = urs({"call", "jp/rt.Diagnostic0", "echo", "{\"text\":\"anyone?\"}"});
  EXPECT_NE(refused.exit_code, 0) << refused.out;
  EXPECT_THAT(refused.out + refused.err, HasSubstr("unreachable"));
  const std::map<std::string, std::string> jp_unavailable{{"space", "jp"}, {"status", "UNAVAILABLE"}};
  EXPECT_TRUE(wait_until(
      [&] {
        after = scrape(kr_metrics_);
        return metric_value(after, "urslink_bridge_link_call_failures_total", jp_unavailable).value_or(0) >= 1.0;
      },
      5s))
      << after;
  shown = urs({"link", "--json", kr_link});
  EXPECT_THAT(shown.out, HasSubstr("{\"space\":\"jp\",\"state\":\"lost\",\"reached_since\":0,")) << shown.out;
  EXPECT_THAT(shown.out, ::testing::ContainsRegex("\"failures\":\\{\"DEADLINE_EXCEEDED\":1,\"UNAVAILABLE\":[1-9]"))
      << shown.out;
  const CommandResult nothing = urs({"link", "127.0.0.1:1"});
  EXPECT_EQ(nothing.exit_code, 1);
  EXPECT_THAT(nothing.err, HasSubstr("urs link: 127.0.0.1:1: Connection refused")) << nothing.err;
  const CommandResult checked = promtool_check_metrics(after);
  EXPECT_EQ(checked.exit_code, 0) << checked.out << checked.err;
  EXPECT_EQ(checked.out + checked.err, "");
}

// A bridge whose CAMUS server is not there is alive but not ready, and says which check fails.
TEST_F(BridgeOperations, ABridgeWithoutItsCamusSessionIsNotReadyAndSaysWhy) {
  auto lonely = launch_bridge("bridge-lonely", "name: bridge-lonely\n" + dds(),
                              {"--server", "127.0.0.1:1", "--metrics-listen", "127.0.0.1:0"}, "lonely");
  ASSERT_TRUE(lonely);
  const uint16_t port = metrics_port(*lonely);
  EXPECT_EQ(http_get(port, "/healthz").status, 200);
  HttpResponse ready;
  EXPECT_TRUE(wait_until(  // active, and joined to the link, once its thread has opened the sides
      [&] {
        ready = http_get(port, "/readyz");
        return ready.body.find("ok side dds") != std::string::npos;
      },
      10s))
      << ready.body;
  EXPECT_EQ(ready.status, 503);
  EXPECT_THAT(ready.body, HasSubstr("ok active"));
  EXPECT_THAT(ready.body, HasSubstr("not ready side camus: not connected to the CAMUS server"));
  EXPECT_EQ(metric_value(scrape(port), "urslink_ready"), 0.0);
}

// A --metrics-listen that cannot be served stops the bridge at start, naming the flag.
TEST_F(BridgeOperations, ABadMetricsListenStopsTheBridgeNamingTheFlag) {
  std::ofstream(dir_ + "/bad.yaml") << "name: bridge-bad\n" + dds();
  for (const std::string& listen : {std::string("no-port"), "127.0.0.1:" + std::to_string(kr_metrics_)}) {
    const CommandResult r = run_command({URS_BRIDGE_BIN, "--space", "bad", "--config", dir_ + "/bad.yaml", "--server",
                                         "127.0.0.1:1", "--metrics-listen", listen},
                                        20s);
    EXPECT_EQ(r.exit_code, 2) << listen << ": " << r.err;
    EXPECT_THAT(r.err, HasSubstr("--metrics-listen")) << listen;
  }
}

// One call followed across both spaces: the trace id `urs call` prints is on kr's bridge's line
// for the call, on jp's bridge's, in jp's audit log and on the line of the RT component that
// served it.
TEST_F(BridgeOperations, OneCallIsFollowedAcrossBothSpacesByItsTraceId) {
  const std::string id = echo_across("followed");
  ASSERT_FALSE(id.empty());
  const std::regex kr_line("trace=" + id + " bridged jp/rt\\.Diagnostic0\\.echo \\(dds -> camus\\): OK in [0-9]+ us");
  const std::regex jp_line("trace=" + id + " bridged rt\\.Diagnostic0\\.echo \\(rt -> dds\\): OK in [0-9]+ us");
  const std::regex served_line("trace=" + id + " served Diagnostic0\\.echo: OK in [0-9]+ us");
  EXPECT_TRUE(wait_until([&] { return std::regex_search(kr_->log(), kr_line); }, 5s)) << kr_->log();
  EXPECT_TRUE(wait_until([&] { return std::regex_search(jp_->log(), jp_line); }, 5s)) << jp_->log();
  EXPECT_TRUE(wait_until([&] { return std::regex_search(manager("m").log(), served_line); }, 5s)) << manager("m").log();
  const std::string audit = dir_ + "/jp-audit.jsonl";
  EXPECT_TRUE(wait_until([&] { return read_text(audit).find("\"trace_id\":\"" + id + "\"") != std::string::npos; }, 5s))
      << read_text(audit);
  // Another call is another trace, in every hop.
  const std::string other = echo_across("again");
  EXPECT_NE(other, id);
  EXPECT_TRUE(wait_until([&] { return jp_->log().find("trace=" + other + " bridged") != std::string::npos; }, 5s));
}

}  // namespace
}  // namespace urs::test
