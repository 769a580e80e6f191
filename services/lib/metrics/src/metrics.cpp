#include "urs/metrics/metrics.hpp"

#include <prometheus/counter.h>
#include <prometheus/gauge.h>
#include <prometheus/histogram.h>
#include <prometheus/text_serializer.h>

#include "process_collector.hpp"
#include "urs/metrics/flags.hpp"

#ifndef URS_VERSION
#define URS_VERSION "unknown"
#endif

namespace urs::metrics {

void Health::add(std::string name, Check check) {
  std::lock_guard<std::mutex> lock(mutex_);
  checks_.emplace_back(std::move(name), std::move(check));
}

Health::Report Health::readiness() const {
  std::vector<std::pair<std::string, Check>> checks;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    checks = checks_;
  }
  Report report;
  for (const auto& [name, check] : checks) {
    std::string why;
    try {
      why = check();
    } catch (const std::exception& e) {
      why = std::string("check failed: ") + e.what();
    }
    if (why.empty()) {
      report.text += "ok " + name + "\n";
    } else {
      report.ready = false;
      report.text += "not ready " + name + ": " + why + "\n";
    }
  }
  return report;
}

// The families read at scrape time.
class Metrics::Scraped final : public prometheus::Collectable {
 public:
  struct Family {
    std::string name;
    std::string help;
    Kind kind;
    std::function<std::vector<Sample>()> read;
  };

  void add(Family family) {
    std::lock_guard<std::mutex> lock(mutex_);
    families_.push_back(std::move(family));
  }

  std::vector<prometheus::MetricFamily> Collect() const override {
    std::vector<Family> families;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      families = families_;
    }
    std::vector<prometheus::MetricFamily> out;
    out.reserve(families.size());
    for (const auto& family : families) {
      prometheus::MetricFamily collected;
      collected.name = family.name;
      collected.help = family.help;
      collected.type = family.kind == Kind::kCounter ? prometheus::MetricType::Counter : prometheus::MetricType::Gauge;
      for (const auto& sample : family.read()) {
        prometheus::ClientMetric metric;
        for (const auto& [name, value] : sample.labels) metric.label.push_back({name, value});
        if (family.kind == Kind::kCounter) {
          metric.counter.value = sample.value;
        } else {
          metric.gauge.value = sample.value;
        }
        collected.metric.push_back(std::move(metric));
      }
      out.push_back(std::move(collected));
    }
    return out;
  }

 private:
  mutable std::mutex mutex_;
  std::vector<Family> families_;
};

namespace {

template <typename Builder>
auto& family(Builder builder, prometheus::Registry& registry, const char* name, const char* help) {
  return builder.Name(name).Help(help).Register(registry);
}

}  // namespace

Metrics::Metrics(Options options)
    : options_(std::move(options)),
      registry_(std::make_shared<prometheus::Registry>()),
      scraped_(std::make_shared<Scraped>()),
      process_(std::make_shared<detail::ProcessCollector>()),
      served_counts_(family(prometheus::BuildCounter(), *registry_, "urslink_served_calls_total",
                            "Calls this process answered, by the middleware they came by, service, operation and "
                            "final status.")),
      served_durations_(family(prometheus::BuildHistogram(), *registry_, "urslink_served_call_duration_seconds",
                               "Time from a call's arrival to its answer, by middleware, service and operation.")),
      client_counts_(family(prometheus::BuildCounter(), *registry_, "urslink_client_calls_total",
                            "Calls this process made, by the middleware they went by, service, operation and final "
                            "status.")),
      client_durations_(family(prometheus::BuildHistogram(), *registry_, "urslink_client_call_duration_seconds",
                               "Time from a call's start to its outcome, by middleware, service and operation.")) {
  prometheus::BuildGauge()
      .Name("urslink_build_info")
      .Help("Which program of which space this is, and its version (always 1).")
      .Register(*registry_)
      .Add({{"program", options_.program}, {"space", options_.space}, {"version", URS_VERSION}})
      .Set(1);
  add_scraped("urslink_ready", "Whether the program is ready (1) or not (0), as its /readyz says.", Kind::kGauge,
              [this] {
                return std::vector<Sample>{{{}, health_.readiness().ready ? 1.0 : 0.0}};
              });
}

Metrics::~Metrics() = default;

CallMetrics& Metrics::calls(std::map<std::string, std::unique_ptr<CallMetrics>>& side,
                            prometheus::Family<prometheus::Counter>& counts,
                            prometheus::Family<prometheus::Histogram>& durations, const std::string& via) {
  std::lock_guard<std::mutex> lock(calls_mutex_);
  auto& slot = side[via];
  if (!slot) slot = std::make_unique<CallMetrics>(counts, durations, via, options_.max_call_series);
  return *slot;
}

CallMetrics& Metrics::served_calls(const std::string& via) {
  return calls(served_, served_counts_, served_durations_, via);
}

CallMetrics& Metrics::client_calls(const std::string& via) {
  return calls(client_, client_counts_, client_durations_, via);
}

void Metrics::add_scraped(std::string name, std::string help, Kind kind, std::function<std::vector<Sample>()> read) {
  scraped_->add({std::move(name), std::move(help), kind, std::move(read)});
}

std::string Metrics::scrape() const {
  auto families = registry_->Collect();
  for (const prometheus::Collectable* collectable : {static_cast<const prometheus::Collectable*>(scraped_.get()),
                                                     static_cast<const prometheus::Collectable*>(process_.get())}) {
    auto more = collectable->Collect();
    families.insert(families.end(), std::make_move_iterator(more.begin()), std::make_move_iterator(more.end()));
  }
  return prometheus::TextSerializer().Serialize(families);
}

std::unique_ptr<Metrics> metrics_for(const std::string& listen, const std::string& program, const std::string& space) {
  if (listen.empty()) return nullptr;
  util::parse_endpoint(listen, "--metrics-listen");  // a bad value is refused before anything starts
  return std::make_unique<Metrics>(Metrics::Options{program, space});
}

std::unique_ptr<HttpEndpoint> serve(const std::string& listen, Metrics* metrics) {
  if (metrics == nullptr) return nullptr;
  return std::make_unique<HttpEndpoint>(util::parse_endpoint(listen, "--metrics-listen"), *metrics);
}

}  // namespace urs::metrics
