#pragma once
// The report of a bench: the Markdown table deploy/bench.sh puts into docs/performance.md, and the
// JSON goals_across_runs.py reads (urs-bench, urs-wan-bench). Each row shows its ratio to its
// baseline, paired repetition by repetition when both were measured in turns, and its goal's state.

#include <cstdio>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "bench_stats.hpp"

namespace urs::bench {

// A measurement that is not a latency row: its name and its value (with "(goal ...: met)" if any).
using Extra = std::pair<std::string, std::string>;

inline std::string fmt_us(double us) {
  char b[32];
  std::snprintf(b, sizeof(b), us >= 1000 ? "%.2f ms" : "%.1f us", us >= 1000 ? us / 1000 : us);
  return b;
}

struct Report {
  std::string markdown;
  std::string json;
};

inline Report report(const std::vector<Row>& rows, const std::vector<Extra>& extras, bool quick) {
  std::ostringstream md;
  md << "| path | payload | median | p99 | spread of medians | vs baseline (spread of per-repetition ratios) | goal |\n"
        "|---|---|---|---|---|---|---|\n";
  std::ostringstream json;
  json << "{\"quick\":" << (quick ? "true" : "false") << ",\"rows\":[";
  for (size_t i = 0; i < rows.size(); ++i) {
    const auto& row = rows[i];
    std::string ratio = row.baseline.empty() ? "baseline" : "– (its baseline not measured)";
    std::string goal = "";
    std::string ratio_json;
    const Row* base = nullptr;
    for (const auto& candidate : rows) {  // the baseline of the same group first
      if (candidate.path + "|" + candidate.payload != row.baseline) continue;
      if (base == nullptr || (candidate.group == row.group && base->group != row.group)) base = &candidate;
    }
    if (base != nullptr) {
      const bool paired = row.group > 0 && base->group == row.group;
      const Ratio x = ratio_of(row.summary, base->summary, paired);
      char b[200];
      if (x.paired) {
        std::snprintf(b, sizeof(b), "%.2fx %s (%.2f – %.2f)", x.median, base->path.c_str(), x.low, x.high);
      } else {
        std::snprintf(b, sizeof(b), "%.2fx %s", x.median, base->path.c_str());
      }
      ratio = b;
      if (row.goal_ratio > 0) {
        std::snprintf(b, sizeof(b), "<= %.3gx: %s", row.goal_ratio, x.median <= row.goal_ratio ? "met" : "missed");
        goal = b;
      }
      std::snprintf(b, sizeof(b), ",\"ratio\":%.4f,\"ratio_low\":%.4f,\"ratio_high\":%.4f,\"paired\":%s,\"goal\":%.4f",
                    x.median, x.low, x.high, x.paired ? "true" : "false", row.goal_ratio);
      ratio_json = b;
    }
    md << "| " << row.path << " | " << row.payload << " | " << fmt_us(row.summary.median_us) << " | "
       << fmt_us(row.summary.p99_us) << " | " << fmt_us(row.summary.min_median_us) << " – "
       << fmt_us(row.summary.max_median_us) << " | " << ratio << " | " << goal << " |\n";
    json << (i ? "," : "") << "{\"path\":\"" << row.path << "\",\"payload\":\"" << row.payload
         << "\",\"median_us\":" << row.summary.median_us << ",\"p99_us\":" << row.summary.p99_us
         << ",\"min_median_us\":" << row.summary.min_median_us << ",\"max_median_us\":" << row.summary.max_median_us
         << ",\"samples\":" << row.summary.samples << ",\"baseline\":\"" << row.baseline << "\"" << ratio_json << "}";
  }
  json << "],\"other\":{";
  md << "\n| measurement | value |\n|---|---|\n";
  for (size_t i = 0; i < extras.size(); ++i) {
    md << "| " << extras[i].first << " | " << extras[i].second << " |\n";
    json << (i ? "," : "") << "\"" << extras[i].first << "\":\"" << extras[i].second << "\"";
  }
  json << "}}\n";
  return {md.str(), json.str()};
}

}  // namespace urs::bench
