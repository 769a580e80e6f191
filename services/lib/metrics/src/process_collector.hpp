#pragma once
// The process's own metrics, read from /proc at each scrape under the names the Prometheus
// clients share (process_cpu_seconds_total, process_resident_memory_bytes,
// process_virtual_memory_bytes, process_open_fds, process_max_fds, process_start_time_seconds),
// and process_threads. A value that cannot be read is left out, never made up.

#include <prometheus/collectable.h>
#include <prometheus/metric_family.h>

#include <vector>

namespace urs::metrics::detail {

class ProcessCollector final : public prometheus::Collectable {
 public:
  std::vector<prometheus::MetricFamily> Collect() const override;
};

}  // namespace urs::metrics::detail
