// urs::metrics::Metrics: what a scrape holds (build info, readiness, the process's own, calls and
// scraped families), clean for `promtool check metrics`; readiness from the checks.

#include "urs/metrics/metrics.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include "metrics_scrape.hpp"
#include "urs/metrics/flags.hpp"
#include "urs/util/cli.hpp"

namespace urs::metrics {
namespace {

using namespace std::chrono_literals;
using test::metric_value;
using ::testing::HasSubstr;

TEST(Metrics, ScrapeHoldsBuildInfoReadinessProcessCallsAndScrapedFamilies) {
  Metrics metrics({"urs-test", "kr"});
  metrics.served_calls("planet").record("diag", "echo", call::Status::OK, 3ms);
  metrics.client_calls("dds").record("jp/rt.Diag0", "echo", call::Status::UNAVAILABLE, 1ms);
  metrics.add_scraped("urslink_test_refusals_total", "Refusals by limit.", Kind::kCounter, [] {
    return std::vector<Sample>{{{{"limit", "max_hello_bytes"}}, 2}, {{{"limit", "max_connections"}}, 0}};
  });
  const std::string text = metrics.scrape();
  EXPECT_EQ(metric_value(text, "urslink_build_info", {{"program", "urs-test"}, {"space", "kr"}}), 1);
  EXPECT_EQ(metric_value(text, "urslink_ready"), 1);
  EXPECT_EQ(metric_value(text, "urslink_served_calls_total",
                         {{"via", "planet"}, {"service", "diag"}, {"operation", "echo"}, {"status", "OK"}}),
            1);
  EXPECT_EQ(metric_value(text, "urslink_served_call_duration_seconds_count", {{"service", "diag"}}), 1);
  EXPECT_EQ(metric_value(text, "urslink_client_calls_total", {{"via", "dds"}, {"status", "UNAVAILABLE"}}), 1);
  EXPECT_EQ(metric_value(text, "urslink_test_refusals_total", {{"limit", "max_hello_bytes"}}), 2);
  EXPECT_GT(*metric_value(text, "process_resident_memory_bytes"), 1e6);
  EXPECT_GE(*metric_value(text, "process_threads"), 1);
  EXPECT_GE(*metric_value(text, "process_open_fds"), 3);
  EXPECT_GT(*metric_value(text, "process_max_fds"), 0);
  EXPECT_GE(*metric_value(text, "process_cpu_seconds_total"), 0);
  EXPECT_GT(*metric_value(text, "process_start_time_seconds"), 1.6e9);

  auto checked = test::promtool_check_metrics(text);
  EXPECT_EQ(checked.exit_code, 0) << checked.out << checked.err;
  EXPECT_EQ(checked.out + checked.err, "");
}

TEST(Metrics, PromtoolWouldCatchABadName) {  // the check above can fail
  Metrics metrics({"urs-test", ""});
  metrics.add_scraped("urslink_test_refusals", "A counter without _total.", Kind::kCounter, [] {
    return std::vector<Sample>{{{}, 1}};
  });
  auto checked = test::promtool_check_metrics(metrics.scrape());
  EXPECT_THAT(checked.out + checked.err, HasSubstr("counter metrics should have \"_total\" suffix"));
}

TEST(Health, ReadyWhenEveryCheckIsAndSaysWhichIsNot) {
  Health health;
  EXPECT_TRUE(health.readiness().ready);
  std::string agents_why = "1 of 2 agents registered";
  health.add("listening", [] { return std::string(); });
  health.add("agents registered", [&] { return agents_why; });
  auto report = health.readiness();
  EXPECT_FALSE(report.ready);
  EXPECT_EQ(report.text, "ok listening\nnot ready agents registered: 1 of 2 agents registered\n");
  agents_why.clear();
  report = health.readiness();
  EXPECT_TRUE(report.ready);
  EXPECT_EQ(report.text, "ok listening\nok agents registered\n");
}

TEST(Health, ACheckThatThrowsIsNotReady) {
  Health health;
  health.add("store", []() -> std::string { throw std::runtime_error("disk gone"); });
  auto report = health.readiness();
  EXPECT_FALSE(report.ready);
  EXPECT_EQ(report.text, "not ready store: check failed: disk gone\n");
}

TEST(Flags, NoListenNoMetricsAndABadOneIsRefusedNamingTheFlag) {
  EXPECT_EQ(metrics_for("", "p", "s"), nullptr);
  EXPECT_EQ(serve("", nullptr), nullptr);
  try {
    metrics_for("nowhere", "p", "s");
    FAIL();
  } catch (const util::ConfigError& e) {
    EXPECT_STREQ(e.what(), "--metrics-listen: 'nowhere' is not HOST:PORT");
  }
}

}  // namespace
}  // namespace urs::metrics
