#pragma once
// A program's metrics in the Prometheus text format (docs/operations.md, "Monitoring"): the
// registry of what its components count as things happen (prometheus-cpp), the families read from
// its components when Prometheus scrapes (add_scraped: refusals, sessions, queue depths), the
// process's own (RSS, threads, open files, CPU) and its readiness (Health). The HTTP endpoint that
// serves them is urs/metrics/http_endpoint.hpp.
//
// A program builds one Metrics when --metrics-listen is given and hands its parts to the
// components it builds; without the flag there is none, and components given none count nothing.
//
// Threading: thread-safe. The calls, families and checks are added while the program starts;
// scrape() runs the scraped families' readers and the readiness checks on the caller's thread.

#include <prometheus/registry.h>

#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

#include "urs/metrics/call_metrics.hpp"

namespace urs::metrics {

// Readiness: checks the program adds (the server listening, a SAM's agents registered, ...), each
// answering "" when it is ready and else why not.
class Health {
 public:
  using Check = std::function<std::string()>;
  // Thread-safe; `check` runs on the thread that asks (the endpoint's), must not block for long
  // and must stay callable for the life of this object.
  void add(std::string name, Check check);

  struct Report {
    bool ready = true;
    std::string text;  // one line per check: "ok <name>" or "not ready <name>: <why>"
  };
  // Runs every check (ready when there are none).
  Report readiness() const;

 private:
  mutable std::mutex mutex_;
  std::vector<std::pair<std::string, Check>> checks_;
};

// One sample of a family read when Prometheus scrapes.
struct Sample {
  std::vector<std::pair<std::string, std::string>> labels;  // values from the code or the catalog only
  double value = 0;
};
enum class Kind { kCounter, kGauge };

class Metrics {
 public:
  struct Options {
    std::string program;            // "urs-camus-server": urslink_build_info's program label
    std::string space;              // the program's space, if it has one
    size_t max_call_series = 1000;  // service/operation pairs with series of their own, per via and side
  };
  explicit Metrics(Options options);
  ~Metrics();
  Metrics(const Metrics&) = delete;
  Metrics& operator=(const Metrics&) = delete;

  // For the families a component counts in itself (prometheus::BuildCounter().Register(...)).
  prometheus::Registry& registry() { return *registry_; }

  // The calls this process answered (urslink_served_calls_total, urslink_served_call_duration_seconds)
  // and those it made (urslink_client_calls_total, urslink_client_call_duration_seconds), by the
  // middleware they came or went by ("planet", "dds", "corba"). Made on first use; the references
  // stay valid for the life of this object.
  CallMetrics& served_calls(const std::string& via);
  CallMetrics& client_calls(const std::string& via);

  // A family whose samples `read` returns at each scrape (what a component counts itself). `name`
  // follows Prometheus conventions (a counter ends in _total). `read` runs on the scraping thread,
  // must not block for long and must stay callable for the life of this object.
  void add_scraped(std::string name, std::string help, Kind kind, std::function<std::vector<Sample>()> read);

  Health& health() { return health_; }
  // Options::max_call_series: for a component's own CallMetrics.
  size_t max_call_series() const { return options_.max_call_series; }

  // Every metric in the Prometheus text format (version 0.0.4), urslink_ready included.
  std::string scrape() const;

 private:
  class Scraped;
  CallMetrics& calls(std::map<std::string, std::unique_ptr<CallMetrics>>& side,
                     prometheus::Family<prometheus::Counter>& counts,
                     prometheus::Family<prometheus::Histogram>& durations, const std::string& via);

  const Options options_;
  std::shared_ptr<prometheus::Registry> registry_;
  std::shared_ptr<Scraped> scraped_;
  std::shared_ptr<prometheus::Collectable> process_;
  prometheus::Family<prometheus::Counter>& served_counts_;
  prometheus::Family<prometheus::Histogram>& served_durations_;
  prometheus::Family<prometheus::Counter>& client_counts_;
  prometheus::Family<prometheus::Histogram>& client_durations_;
  std::mutex calls_mutex_;
  std::map<std::string, std::unique_ptr<CallMetrics>> served_;
  std::map<std::string, std::unique_ptr<CallMetrics>> client_;
  Health health_;
};

}  // namespace urs::metrics
