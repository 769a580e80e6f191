#include "urs/metrics/call_metrics.hpp"

#include <mutex>

namespace urs::metrics {

const prometheus::Histogram::BucketBoundaries& call_duration_buckets() {
  static const prometheus::Histogram::BucketBoundaries kBuckets = {
      0.0001, 0.00025, 0.0005, 0.001, 0.0025, 0.005, 0.01, 0.025, 0.05, 0.1, 0.25, 0.5, 1, 2.5, 5, 10, 30};
  return kBuckets;
}

CallMetrics::CallMetrics(prometheus::Family<prometheus::Counter>& calls,
                         prometheus::Family<prometheus::Histogram>& durations, std::string via, size_t max_series)
    : CallMetrics(calls, durations, prometheus::Labels{{"via", std::move(via)}}, max_series) {}

CallMetrics::CallMetrics(prometheus::Family<prometheus::Counter>& calls,
                         prometheus::Family<prometheus::Histogram>& durations, prometheus::Labels fixed,
                         size_t max_series)
    : calls_(calls), durations_(durations), fixed_(std::move(fixed)), max_series_(max_series) {
  other_ = std::make_unique<Series>();
  other_->service = kOther;
  other_->operation = kOther;
  other_->duration = &durations_.Add(labels(kOther, kOther), call_duration_buckets());
}

prometheus::Labels CallMetrics::labels(const std::string& service, const std::string& operation,
                                       const std::string& status) const {
  prometheus::Labels labels = fixed_;
  labels["service"] = service;
  labels["operation"] = operation;
  if (!status.empty()) labels["status"] = status;
  return labels;
}

void CallMetrics::record(const std::string& service, const std::string& operation, call::Status status,
                         std::chrono::steady_clock::duration elapsed) noexcept {
  try {
    Series& series = series_of(service, operation);
    counter_of(series, status).Increment();
    series.duration->Observe(std::chrono::duration<double>(elapsed).count());
  } catch (...) {
    // A metric that cannot be recorded (out of memory) never fails the call it describes.
  }
}

void CallMetrics::record_unchecked(const std::string& service, const std::string& operation, call::Status status,
                                   std::chrono::steady_clock::duration elapsed) noexcept {
  try {
    Series& series = series_of(service, operation, call::CallRecorder::confirms(status));
    counter_of(series, status).Increment();
    series.duration->Observe(std::chrono::duration<double>(elapsed).count());
  } catch (...) {
    // A metric that cannot be recorded (out of memory) never fails the call it describes.
  }
}

size_t CallMetrics::series() const {
  std::shared_lock<std::shared_mutex> lock(mutex_);
  return count_;
}

CallMetrics::Series& CallMetrics::series_of(const std::string& service, const std::string& operation, bool make) {
  if (service.empty() || operation.empty()) return *other_;
  {
    std::shared_lock<std::shared_mutex> lock(mutex_);
    auto by_service = by_name_.find(service);
    if (by_service != by_name_.end()) {
      auto it = by_service->second.find(operation);
      if (it != by_service->second.end()) return *it->second;
    }
    if (!make || count_ >= max_series_) return *other_;
  }
  return make_series(service, operation);
}

CallMetrics::Series& CallMetrics::make_series(const std::string& service, const std::string& operation) {
  std::unique_lock<std::shared_mutex> lock(mutex_);
  auto by_service = by_name_.find(service);
  if (by_service != by_name_.end()) {
    auto it = by_service->second.find(operation);
    if (it != by_service->second.end()) return *it->second;  // another thread made it meanwhile
  }
  if (count_ >= max_series_) return *other_;
  auto series = std::make_unique<Series>();
  series->service = service;
  series->operation = operation;
  series->duration = &durations_.Add(labels(service, operation), call_duration_buckets());
  auto& slot = by_name_[service][operation];
  slot = std::move(series);
  ++count_;
  return *slot;
}

prometheus::Counter& CallMetrics::counter_of(Series& series, call::Status status) {
  auto number = static_cast<size_t>(call::status_number(status));
  if (number >= series.calls.size()) number = static_cast<size_t>(call::status_number(call::Status::INTERNAL));
  if (auto* counter = series.calls[number].load(std::memory_order_acquire)) return *counter;
  // Family::Add returns the same counter for the same labels, so two threads racing here agree.
  auto& counter = calls_.Add(
      labels(series.service, series.operation, std::string(call::status_name(static_cast<call::Status>(number)))));
  series.calls[number].store(&counter, std::memory_order_release);
  return counter;
}

}  // namespace urs::metrics
