#pragma once
// Latency samples → median / p99 / spread over repetitions, and the report table.

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <string>
#include <vector>

namespace urs::bench {

struct Summary {
  double median_us = 0;
  double p99_us = 0;
  double min_median_us = 0;  // spread of the per-repetition medians
  double max_median_us = 0;
  size_t samples = 0;
};

inline double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  size_t index = static_cast<size_t>(p * static_cast<double>(v.size() - 1) + 0.5);
  return v[std::min(index, v.size() - 1)];
}

// `repetitions` rounds of `iterations` timed calls of `once` after `warmup` untimed ones.
template <class F>
Summary measure(F&& once, int warmup, int iterations, int repetitions) {
  for (int i = 0; i < warmup; ++i) once();
  std::vector<double> all;
  std::vector<double> medians;
  for (int r = 0; r < repetitions; ++r) {
    std::vector<double> round;
    round.reserve(static_cast<size_t>(iterations));
    for (int i = 0; i < iterations; ++i) {
      auto t0 = std::chrono::steady_clock::now();
      once();
      round.push_back(std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t0).count());
    }
    medians.push_back(percentile(round, 0.5));
    all.insert(all.end(), round.begin(), round.end());
  }
  Summary s;
  s.median_us = percentile(all, 0.5);
  s.p99_us = percentile(all, 0.99);
  s.min_median_us = *std::min_element(medians.begin(), medians.end());
  s.max_median_us = *std::max_element(medians.begin(), medians.end());
  s.samples = all.size();
  return s;
}

struct Row {
  std::string path;
  std::string payload;
  Summary summary;
  std::string baseline;  // name of the row this one is compared with ("" for baselines)
  double goal_ratio = 0; // goal: median <= goal_ratio x baseline median (0 = none)
};

}  // namespace urs::bench
