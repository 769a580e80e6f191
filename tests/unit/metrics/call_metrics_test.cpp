// urs::metrics::CallMetrics: one counter per service, operation and status, one histogram per
// service and operation, names outside the catalog and pairs past the cap counted as "other".

#include "urs/metrics/call_metrics.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <prometheus/registry.h>

#include <thread>
#include <vector>

namespace urs::metrics {
namespace {

using namespace std::chrono_literals;

struct Families {
  prometheus::Registry registry;
  prometheus::Family<prometheus::Counter>& calls =
      prometheus::BuildCounter().Name("t_calls_total").Help("h").Register(registry);
  prometheus::Family<prometheus::Histogram>& durations =
      prometheus::BuildHistogram().Name("t_call_duration_seconds").Help("h").Register(registry);

  // The counter's value for these labels, or -1 if it has none.
  double count(const std::string& service, const std::string& operation, const std::string& status) const {
    for (const auto& family : registry.Collect()) {
      if (family.name != "t_calls_total") continue;
      for (const auto& metric : family.metric) {
        std::map<std::string, std::string> labels;
        for (const auto& label : metric.label) labels[label.name] = label.value;
        if (labels["service"] == service && labels["operation"] == operation && labels["status"] == status) {
          EXPECT_EQ(labels["via"], "planet");
          return metric.counter.value;
        }
      }
    }
    return -1;
  }
  // The histogram's sample count and sum for these labels.
  std::pair<uint64_t, double> observed(const std::string& service, const std::string& operation) const {
    for (const auto& family : registry.Collect()) {
      if (family.name != "t_call_duration_seconds") continue;
      for (const auto& metric : family.metric) {
        std::map<std::string, std::string> labels;
        for (const auto& label : metric.label) labels[label.name] = label.value;
        if (labels["service"] == service && labels["operation"] == operation) {
          return {metric.histogram.sample_count, metric.histogram.sample_sum};
        }
      }
    }
    return {0, 0};
  }
  size_t counter_series() const {
    for (const auto& family : registry.Collect()) {
      if (family.name == "t_calls_total") return family.metric.size();
    }
    return 0;
  }
};

TEST(CallMetrics, CountsByServiceOperationAndStatusAndObservesLatency) {
  Families f;
  CallMetrics metrics(f.calls, f.durations, "planet", 100);
  metrics.record("diag", "echo", call::Status::OK, 2ms);
  metrics.record("diag", "echo", call::Status::OK, 4ms);
  metrics.record("diag", "echo", call::Status::DEADLINE_EXCEEDED, 10ms);
  metrics.record("diag", "add", call::Status::OK, 1ms);
  EXPECT_EQ(f.count("diag", "echo", "OK"), 2);
  EXPECT_EQ(f.count("diag", "echo", "DEADLINE_EXCEEDED"), 1);
  EXPECT_EQ(f.count("diag", "add", "OK"), 1);
  EXPECT_EQ(f.count("diag", "add", "DEADLINE_EXCEEDED"), -1);  // series only for what happened
  auto [count, sum] = f.observed("diag", "echo");
  EXPECT_EQ(count, 3u);
  EXPECT_NEAR(sum, 0.016, 1e-9);
  EXPECT_EQ(metrics.series(), 2u);
}

TEST(CallMetrics, NamesOutsideTheCatalogAreOther) {
  Families f;
  CallMetrics metrics(f.calls, f.durations, "planet", 100);
  metrics.record("", "", call::Status::UNKNOWN_SERVICE, 1ms);
  metrics.record("diag", "", call::Status::UNKNOWN_OPERATION, 1ms);
  EXPECT_EQ(f.count(kOther, kOther, "UNKNOWN_SERVICE"), 1);
  EXPECT_EQ(f.count(kOther, kOther, "UNKNOWN_OPERATION"), 1);
  EXPECT_EQ(metrics.series(), 0u);
}

TEST(CallMetrics, PairsPastTheCapAreOther) {
  Families f;
  CallMetrics metrics(f.calls, f.durations, "planet", 3);
  for (int i = 0; i < 50; ++i) metrics.record("s" + std::to_string(i), "op", call::Status::OK, 1ms);
  EXPECT_EQ(metrics.series(), 3u);
  EXPECT_EQ(f.count("s2", "op", "OK"), 1);
  EXPECT_EQ(f.count("s3", "op", "OK"), -1);
  EXPECT_EQ(f.count(kOther, kOther, "OK"), 47);
  EXPECT_EQ(f.counter_series(), 4u);
  metrics.record("s1", "op", call::Status::OK, 1ms);  // admitted before the cap: still its own
  EXPECT_EQ(f.count("s1", "op", "OK"), 2);
}

TEST(CallMetrics, ThreadsRecordingTheSamePairCountEveryCall) {
  Families f;
  CallMetrics metrics(f.calls, f.durations, "planet", 10);
  std::vector<std::thread> threads;
  for (int t = 0; t < 4; ++t) {
    threads.emplace_back([&] {
      for (int i = 0; i < 1000; ++i) metrics.record("diag", "op" + std::to_string(i % 20), call::Status::OK, 1us);
    });
  }
  for (auto& thread : threads) thread.join();
  double total = 0;
  for (int i = 0; i < 20; ++i) total += std::max(0.0, f.count("diag", "op" + std::to_string(i), "OK"));
  total += f.count(kOther, kOther, "OK");
  EXPECT_EQ(total, 4000);
  EXPECT_EQ(metrics.series(), 10u);
}

}  // namespace
}  // namespace urs::metrics
