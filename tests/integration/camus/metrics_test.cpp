// urs-camus-server's --metrics-listen as a real process: what Prometheus scrapes after real Planet
// traffic (calls by service, operation and status; sessions; events; refusals by limit;
// authentication failures by reason), clean for promtool, and its health endpoints.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <future>
#include <sstream>

#include "camus.pb.h"
#include "metrics_scrape.hpp"
#include "process.hpp"
#include "raw_peer.hpp"
#include "urs/planet/client.hpp"

namespace urs::camus_server::test {
namespace {

using namespace std::chrono_literals;
using ::testing::HasSubstr;
using urs::test::metric_sum;
using urs::test::metric_value;
using urs::test::Process;

class CamusMetricsTest : public ::testing::Test {
 protected:
  void SetUp() override { dir_ = urs::test::make_temp_dir("camus-metrics"); }
  void TearDown() override {
    if (HasFailure() && server_) std::cerr << "---- server log\n" << server_->log();
    clients_.clear();
    server_.reset();
    std::filesystem::remove_all(dir_);
  }

  void start_server(const std::vector<std::string>& extra = {}) {
    std::vector<std::string> argv{URS_CAMUS_SERVER_BIN, "--space",     "kr",           "--listen",
                                  "127.0.0.1:0",        "--port-file", dir_ + "/port", "--metrics-listen",
                                  "127.0.0.1:0",        "--log-level", "debug"};
    argv.insert(argv.end(), extra.begin(), extra.end());
    server_ = std::make_unique<Process>(argv, dir_ + "/server.log");
    ASSERT_TRUE(urs::test::wait_until([&] { return std::filesystem::exists(dir_ + "/port"); }, 10s)) << server_->log();
    port_ = static_cast<uint16_t>(std::stoi(urs::test::read_text(dir_ + "/port")));
    ASSERT_TRUE(urs::test::wait_until([&] { return urs::test::metrics_port_in_log(server_->log()).has_value(); }, 10s));
    metrics_port_ = *urs::test::metrics_port_in_log(server_->log());
  }

  planet::Client& connect(const std::string& token = "") {
    planet::ClientOptions options;
    options.port = port_;
    options.token = token;
    options.role = planet::OPERATOR;
    clients_.push_back(std::make_unique<planet::Client>(options));
    clients_.back()->start();
    EXPECT_TRUE(clients_.back()->wait_connected(5s)) << clients_.back()->last_error();
    return *clients_.back();
  }

  std::string scrape() {
    auto response = urs::test::http_get(metrics_port_, "/metrics");
    EXPECT_EQ(response.status, 200);
    return response.body;
  }

  std::string dir_;
  uint16_t port_ = 0;
  uint16_t metrics_port_ = 0;
  std::unique_ptr<Process> server_;
  std::vector<std::unique_ptr<planet::Client>> clients_;
};

TEST_F(CamusMetricsTest, CallsSessionsAndEventsAsPrometheusScrapesThem) {
  start_server();
  auto& client = connect();
  const std::string before = scrape();
  camus::ContextSetRequest set;
  set.set_key("door");
  set.mutable_value()->set_string_value("open");
  for (int i = 0; i < 3; ++i) ASSERT_TRUE(client.call("camus.context", "Set", set.SerializeAsString(), 5s).ok());
  camus::ContextGetRequest get;
  get.set_key("nosuch");
  EXPECT_EQ(client.call("camus.context", "Get", get.SerializeAsString(), 5s).status, planet::NOT_FOUND);
  EXPECT_EQ(client.call("no.such.service", "Anything", "", 5s).status, planet::UNKNOWN_SERVICE);
  EXPECT_EQ(client.call("camus.context", "Explode", "", 5s).status, planet::UNKNOWN_OPERATION);
  std::promise<void> delivered;
  client.subscribe("lab/#", [&](const planet::Event&) { delivered.set_value(); });
  ASSERT_TRUE(client.publish_and_wait("lab/door", "x", "", 5s).ok());
  ASSERT_EQ(delivered.get_future().wait_for(5s), std::future_status::ready);

  const std::string text = scrape();
  // What a series rose by between the two scrapes (a series first seen in the second rose from 0).
  auto rose = [&](const std::string& name, const std::map<std::string, std::string>& labels) -> std::optional<double> {
    const auto after = metric_value(text, name, labels);
    if (!after) return std::nullopt;
    return *after - metric_value(before, name, labels).value_or(0);
  };
  auto calls = [&](const std::string& service, const std::string& operation, const std::string& status) {
    return rose("urslink_served_calls_total",
                {{"via", "planet"}, {"service", service}, {"operation", operation}, {"status", status}});
  };
  EXPECT_EQ(calls("camus.context", "Set", "OK"), 3);
  EXPECT_EQ(calls("camus.context", "Get", "NOT_FOUND"), 1);
  EXPECT_EQ(calls("camus.context", "Get", "OK"), std::nullopt);  // no such call, no such series
  // Names outside the registry never become labels.
  EXPECT_EQ(calls("other", "other", "UNKNOWN_SERVICE"), 1);
  EXPECT_EQ(calls("camus.context", "Explode", "UNKNOWN_OPERATION"), std::nullopt);
  EXPECT_EQ(calls("other", "other", "UNKNOWN_OPERATION"), 1);
  EXPECT_THAT(text, ::testing::Not(HasSubstr("no.such.service")));
  EXPECT_EQ(rose("urslink_served_call_duration_seconds_count", {{"service", "camus.context"}, {"operation", "Set"}}),
            3);
  // Every served call is in exactly one series: the six made, and none other.
  EXPECT_EQ(metric_sum(text, "urslink_served_calls_total") - metric_sum(before, "urslink_served_calls_total"), 6);
  EXPECT_EQ(metric_value(text, "urslink_planet_sessions"), 1);
  EXPECT_EQ(metric_value(text, "urslink_planet_connections"), 1);
  EXPECT_GE(*metric_value(text, "urslink_camus_events_published_total"), 4);  // 3 context changes and lab/door
  EXPECT_GE(*metric_value(text, "urslink_camus_event_deliveries_total"), 1);
  EXPECT_EQ(metric_value(text, "urslink_camus_subscriptions"), 1);
  EXPECT_EQ(metric_value(text, "urslink_camus_pending_calls"), 0);
  EXPECT_EQ(metric_value(text, "urslink_refusals_total", {{"limit", "max_pending_calls_per_session"}}), 0);
  EXPECT_EQ(metric_value(text, "urslink_build_info", {{"program", "urs-camus-server"}, {"space", "kr"}}), 1);
  EXPECT_GT(*metric_value(text, "process_resident_memory_bytes"), 0);

  auto checked = urs::test::promtool_check_metrics(text);
  EXPECT_EQ(checked.exit_code, 0) << checked.out << checked.err;
  EXPECT_EQ(checked.out + checked.err, "") << text;

  EXPECT_EQ(urs::test::http_get(metrics_port_, "/healthz").status, 200);
  auto ready = urs::test::http_get(metrics_port_, "/readyz");
  EXPECT_EQ(ready.status, 200);
  EXPECT_EQ(ready.body, "ok listening\n");
}

TEST_F(CamusMetricsTest, RefusalsByLimitAndAuthenticationFailuresByReason) {
  std::ofstream(dir_ + "/token") << "right-token\n";
  start_server({"--token-file", dir_ + "/token", "--token-role", "operator", "--max-hello-bytes", "1024",
                "--max-pending-calls-per-session", "1"});
  {
    planet::ClientOptions options;
    options.port = port_;
    options.token = "wrong-token";
    planet::Client wrong(options);
    wrong.start();
    EXPECT_TRUE(urs::test::wait_until([&] { return wrong.last_error().find("wrong token") != std::string::npos; }, 5s))
        << wrong.last_error();
  }
  {
    urs::test::RawPeer peer(port_);
    peer.send_hello(planet::kProtocolVersion, "right-token", std::string(2000, 'n'));  // a Hello over 1024 bytes
    EXPECT_TRUE(urs::test::wait_until([&] { return !peer.send_bytes_checked(std::string(1, '\0')); }, 5s));
  }
  auto& client = connect("right-token");
  // Two calls at once on one connection over max_pending_calls_per_session 1: one is refused.
  std::promise<planet::CallResult> first;
  std::promise<planet::CallResult> second;
  client.call_async("camus.tasks", "List", "", 5s, [&](planet::CallResult r) { first.set_value(std::move(r)); });
  client.call_async("camus.tasks", "List", "", 5s, [&](planet::CallResult r) { second.set_value(std::move(r)); });
  const auto a = first.get_future().get();
  const auto b = second.get_future().get();
  const bool one_refused = (a.status == planet::RESOURCE_EXHAUSTED) != (b.status == planet::RESOURCE_EXHAUSTED);

  const std::string text = scrape();
  EXPECT_GE(*metric_value(text, "urslink_planet_authentication_failures_total", {{"reason", "wrong_token"}}), 1);
  EXPECT_EQ(metric_value(text, "urslink_planet_authentication_failures_total", {{"reason", "token_required"}}), 0);
  EXPECT_EQ(metric_value(text, "urslink_refusals_total", {{"limit", "max_hello_bytes"}}), 1);
  EXPECT_EQ(metric_value(text, "urslink_planet_protocol_errors_total", {{"error", "FRAME_TOO_LARGE"}}), 1);
  if (one_refused) {
    EXPECT_EQ(metric_value(text, "urslink_refusals_total", {{"limit", "max_pending_calls_per_session"}}), 1);
    EXPECT_EQ(metric_value(text, "urslink_served_calls_total",
                           {{"service", "camus.tasks"}, {"operation", "List"}, {"status", "RESOURCE_EXHAUSTED"}}),
              1);
  }
  auto checked = urs::test::promtool_check_metrics(text);
  EXPECT_EQ(checked.out + checked.err, "");
}

// --log-format json: every line one JSON object; the lines of a call carry its trace id, the one
// its client sent.
TEST_F(CamusMetricsTest, JsonLogLinesCarryTheTraceOfTheCall) {
  start_server({"--log-format", "json"});
  auto& client = connect();
  const auto trace = util::TraceContext::start();
  std::promise<planet::CallResult> done;
  client.call_async(
      "camus.tasks", "List", "", 5s, [&](planet::CallResult r) { done.set_value(std::move(r)); }, trace);
  ASSERT_TRUE(done.get_future().get().ok());
  const std::string wanted = "\"trace_id\":\"" + trace.trace_id_hex() + "\"";
  ASSERT_TRUE(urs::test::wait_until([&] { return server_->log().find(wanted) != std::string::npos; }, 5s))
      << server_->log();
  std::istringstream lines(server_->log());
  int objects = 0;
  for (std::string line; std::getline(lines, line);) {
    EXPECT_THAT(line, ::testing::MatchesRegex("\\{\"time\":\"[0-9T:.Z-]+\",\"level\":\"[a-z]+\",\"program\":"
                                              "\"urs-camus-server\",\"space\":\"kr\",.*\"message\":\".*\"\\}"));
    if (line.find(wanted) != std::string::npos) {
      EXPECT_THAT(line, HasSubstr("\"message\":\"call camus.tasks.List from anonymous: OK in "));
    }
    ++objects;
  }
  EXPECT_GT(objects, 3);
}

TEST_F(CamusMetricsTest, WithoutTheFlagThereIsNoEndpoint) {
  std::filesystem::remove(dir_ + "/port");
  server_ = std::make_unique<Process>(std::vector<std::string>{URS_CAMUS_SERVER_BIN, "--space", "kr", "--listen",
                                                               "127.0.0.1:0", "--port-file", dir_ + "/port"},
                                      dir_ + "/server.log");
  ASSERT_TRUE(urs::test::wait_until([&] { return std::filesystem::exists(dir_ + "/port"); }, 10s));
  EXPECT_THAT(server_->log(), ::testing::Not(HasSubstr("metrics: serving")));
}

TEST_F(CamusMetricsTest, ABadMetricsListenIsRefusedNamingTheFlag) {
  auto r = urs::test::run_command(
      {URS_CAMUS_SERVER_BIN, "--space", "kr", "--listen", "127.0.0.1:0", "--metrics-listen", "nowhere"});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_EQ(r.err, "urs-camus-server: --metrics-listen: 'nowhere' is not HOST:PORT\n");
}

}  // namespace
}  // namespace urs::camus_server::test
