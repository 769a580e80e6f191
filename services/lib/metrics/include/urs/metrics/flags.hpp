#pragma once
// --metrics-listen HOST:PORT, the flag of every long-running program (off by default), and what a
// program builds from it. Header-only for the flag (CLI11's App is a template parameter).

#include <memory>
#include <string>

#include "urs/metrics/http_endpoint.hpp"
#include "urs/metrics/metrics.hpp"

namespace urs::metrics {

template <typename App>
void add_metrics_flag(App& app, std::string& listen) {
  app.add_option("--metrics-listen", listen,
                 "Serve Prometheus metrics (/metrics), /healthz and /readyz over HTTP on HOST:PORT (off when not "
                 "given; docs/operations.md, \"Monitoring\")");
}

// A program's metrics and their endpoint, when --metrics-listen was given.
struct Served {
  std::unique_ptr<Metrics> metrics;
  std::unique_ptr<HttpEndpoint> endpoint;
  Metrics* get() const { return metrics.get(); }
};

// Metrics for `program` of `space` (built, not yet served). Null when `listen` is empty.
std::unique_ptr<Metrics> metrics_for(const std::string& listen, const std::string& program, const std::string& space);
// Starts serving `metrics` on `listen` (checked: util::ConfigError naming --metrics-listen). Null
// when `metrics` is null.
std::unique_ptr<HttpEndpoint> serve(const std::string& listen, Metrics* metrics);

}  // namespace urs::metrics
