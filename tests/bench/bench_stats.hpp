#pragma once
// Latency samples → median / p99 / spread over repetitions, and the report table.

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <functional>
#include <string>
#include <thread>
#include <vector>

namespace urs::bench {

struct Summary {
  double median_us = 0;
  double p99_us = 0;
  double min_median_us = 0;  // spread of the per-repetition medians
  double max_median_us = 0;
  size_t samples = 0;
  std::vector<double> medians;  // of each repetition, in order
};

inline double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  size_t index = static_cast<size_t>(p * static_cast<double>(v.size() - 1) + 0.5);
  return v[std::min(index, v.size() - 1)];
}

// One round: `iterations` timed calls of `once`, in microseconds.
template <class F>
std::vector<double> timed_round(F& once, int iterations) {
  std::vector<double> round;
  round.reserve(static_cast<size_t>(iterations));
  for (int i = 0; i < iterations; ++i) {
    auto t0 = std::chrono::steady_clock::now();
    once();
    round.push_back(std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t0).count());
  }
  return round;
}

// Accumulates the rounds of one path into its Summary.
class SummaryBuilder {
 public:
  void add(const std::vector<double>& round) {
    summary_.medians.push_back(percentile(round, 0.5));
    all_.insert(all_.end(), round.begin(), round.end());
  }
  Summary done() {
    summary_.median_us = percentile(all_, 0.5);
    summary_.p99_us = percentile(all_, 0.99);
    summary_.min_median_us = *std::min_element(summary_.medians.begin(), summary_.medians.end());
    summary_.max_median_us = *std::max_element(summary_.medians.begin(), summary_.medians.end());
    summary_.samples = all_.size();
    return summary_;
  }

 private:
  Summary summary_;
  std::vector<double> all_;
};

// `repetitions` rounds of `iterations` timed calls of `once` after `warmup` untimed ones.
template <class F>
Summary measure(F&& once, int warmup, int iterations, int repetitions) {
  for (int i = 0; i < warmup; ++i) once();
  SummaryBuilder builder;
  for (int r = 0; r < repetitions; ++r) builder.add(timed_round(once, iterations));
  return builder.done();
}

// Measures `paths` in turns: every repetition runs one round of each path, one after the other,
// so that a path and its baseline see the same modes of the machine (on a small VM a wake-up lands
// on an idle or a busy core, and a whole round can sit in one mode). A ratio between two paths of
// one call is then taken per repetition (ratio_of), not between medians measured minutes apart.
inline std::vector<Summary> measure_interleaved(const std::vector<std::function<void()>>& paths, int warmup,
                                                int iterations, int repetitions) {
  for (const auto& once : paths) {
    for (int i = 0; i < warmup; ++i) once();
  }
  std::vector<SummaryBuilder> builders(paths.size());
  for (int r = 0; r < repetitions; ++r) {
    for (size_t p = 0; p < paths.size(); ++p) builders[p].add(timed_round(paths[p], iterations));
  }
  std::vector<Summary> out;
  for (auto& builder : builders) out.push_back(builder.done());
  return out;
}

// A path made of others run one after the other (the native hops a bridged call adds up): the
// sums of their medians, repetition by repetition.
inline Summary sum_of(const std::vector<const Summary*>& parts) {
  Summary sum;
  for (const Summary* part : parts) {
    sum.median_us += part->median_us;
    sum.p99_us += part->p99_us;
    if (sum.medians.empty()) sum.medians.assign(part->medians.size(), 0.0);
    for (size_t r = 0; r < sum.medians.size() && r < part->medians.size(); ++r) sum.medians[r] += part->medians[r];
  }
  if (!sum.medians.empty()) {
    sum.min_median_us = *std::min_element(sum.medians.begin(), sum.medians.end());
    sum.max_median_us = *std::max_element(sum.medians.begin(), sum.medians.end());
  }
  return sum;
}

// How a path compares with its baseline.
struct Ratio {
  double median = 0;  // the ratio
  double low = 0;     // the spread of the per-repetition ratios (equal to median when not interleaved)
  double high = 0;
  bool paired = false;  // true: the median of per-repetition ratios of paths measured in turns
};

// Paired repetition by repetition when both were measured in turns (`interleaved`), else the
// ratio of the overall medians.
inline Ratio ratio_of(const Summary& path, const Summary& baseline, bool interleaved) {
  Ratio ratio;
  if (interleaved && !path.medians.empty() && path.medians.size() == baseline.medians.size()) {
    std::vector<double> per_repetition;
    for (size_t r = 0; r < path.medians.size(); ++r) per_repetition.push_back(path.medians[r] / baseline.medians[r]);
    ratio.median = percentile(per_repetition, 0.5);
    ratio.low = *std::min_element(per_repetition.begin(), per_repetition.end());
    ratio.high = *std::max_element(per_repetition.begin(), per_repetition.end());
    ratio.paired = true;
    return ratio;
  }
  ratio.median = ratio.low = ratio.high = baseline.median_us > 0 ? path.median_us / baseline.median_us : 0;
  return ratio;
}

// calls/s of `call` run by `clients` threads for `per_client` calls each.
template <class MakeCall>
double throughput(int clients, int per_client, MakeCall make_call) {
  std::vector<std::function<void()>> calls;
  for (int c = 0; c < clients; ++c) calls.push_back(make_call(c));
  const auto t0 = std::chrono::steady_clock::now();
  std::vector<std::thread> threads;
  for (auto& call : calls) {
    threads.emplace_back([&call, per_client] {
      for (int i = 0; i < per_client; ++i) call();
    });
  }
  for (auto& t : threads) t.join();
  return clients * per_client / std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

struct Row {
  std::string path;
  std::string payload;
  Summary summary;
  std::string baseline;   // name of the row this one is compared with ("" for baselines)
  double goal_ratio = 0;  // goal: median <= goal_ratio x baseline median (0 = none)
  int group = 0;          // rows of one group > 0 were measured in turns (measure_interleaved)
};

}  // namespace urs::bench
