#pragma once
// Calls ended at one hop, as Prometheus series: a counter by service, operation and final status,
// and a latency histogram by service and operation (the status would multiply its buckets by
// fifteen; the counter tells errors apart), both labelled with the middleware the calls came or
// went by (`via`: planet, dds, corba), or with other fixed labels (the bridge's `direction`).
//
// Label cardinality is bounded: the names come from the hop's catalog (call::CallRecorder), an
// empty one is "other", and past `max_series` service/operation pairs every new pair is counted
// under service="other", operation="other".
//
// Threading: record() is thread-safe and lock-free once a pair's series exist (a shared lock and
// atomic loads); creating a series takes an exclusive lock once.

#include <prometheus/counter.h>
#include <prometheus/family.h>
#include <prometheus/histogram.h>
#include <prometheus/labels.h>

#include <array>
#include <atomic>
#include <memory>
#include <shared_mutex>
#include <string>
#include <unordered_map>

#include "urs/call/recorder.hpp"

namespace urs::metrics {

// The label value of names outside the catalog and of pairs past the cap.
inline constexpr const char* kOther = "other";

// Latency buckets, in seconds: from 100 µs (a call inside one machine) to 30 s (deadlines).
const prometheus::Histogram::BucketBoundaries& call_duration_buckets();

class CallMetrics final : public call::CallRecorder {
 public:
  // Series are added to `calls` (labels via, service, operation, status) and `durations` (via,
  // service, operation), which must outlive this object.
  CallMetrics(prometheus::Family<prometheus::Counter>& calls, prometheus::Family<prometheus::Histogram>& durations,
              std::string via, size_t max_series);
  // The same with `fixed` labels on every series in place of `via` (values from the code or the
  // configuration only, never from a peer).
  CallMetrics(prometheus::Family<prometheus::Counter>& calls, prometheus::Family<prometheus::Histogram>& durations,
              prometheus::Labels fixed, size_t max_series);
  CallMetrics(const CallMetrics&) = delete;
  CallMetrics& operator=(const CallMetrics&) = delete;

  // call::CallRecorder
  void record(const std::string& service, const std::string& operation, call::Status status,
              std::chrono::steady_clock::duration elapsed) noexcept override;
  void record_unchecked(const std::string& service, const std::string& operation, call::Status status,
                        std::chrono::steady_clock::duration elapsed) noexcept override;

  // Service/operation pairs with series of their own (the "other" pair not counted).
  size_t series() const;

 private:
  struct Series {
    std::string service;
    std::string operation;
    prometheus::Histogram* duration = nullptr;
    std::array<std::atomic<prometheus::Counter*>, call::kLastStatus + 1> calls{};
  };
  // The pair's series, made if there is room when `make`; else (or past the cap) the "other" one.
  Series& series_of(const std::string& service, const std::string& operation, bool make = true);
  Series& make_series(const std::string& service, const std::string& operation);
  prometheus::Counter& counter_of(Series& series, call::Status status);
  // `fixed_` with the pair's names (and `status`, when given).
  prometheus::Labels labels(const std::string& service, const std::string& operation,
                            const std::string& status = {}) const;

  prometheus::Family<prometheus::Counter>& calls_;
  prometheus::Family<prometheus::Histogram>& durations_;
  const prometheus::Labels fixed_;
  const size_t max_series_;
  mutable std::shared_mutex mutex_;
  // service -> operation -> its series; `other_` is the one of every name outside them.
  std::unordered_map<std::string, std::unordered_map<std::string, std::unique_ptr<Series>>> by_name_;
  size_t count_ = 0;
  std::unique_ptr<Series> other_;
};

}  // namespace urs::metrics
