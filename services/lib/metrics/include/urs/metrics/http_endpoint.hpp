#pragma once
// The HTTP endpoint of --metrics-listen HOST:PORT: GET (or HEAD)
//   /metrics  the program's Metrics in the Prometheus text format (version 0.0.4)
//   /healthz  200 "ok": the process is alive and answering
//   /readyz   200 with one "ok <check>" line per readiness check, or 503 with the failed ones
//             ("not ready <check>: <why>")
// Anything else is 404, another method 405.
//
// A minimal HTTP/1.1 server on Asio rather than prometheus-cpp's Exposer: the Exposer (civetweb)
// answers only with collected metrics, always 200, so it cannot serve a /readyz that says 503.
// What a peer sends is bounded before it is read: a request head of at most 8 KiB, 5 s to send
// it, 16 connections at once (more are closed at once); one request per connection.
//
// Threading: one thread of its own, which reads the metrics and runs the readiness checks;
// started by the constructor, stopped and joined by the destructor.

#include <cstdint>
#include <memory>

#include "urs/metrics/metrics.hpp"
#include "urs/util/cli.hpp"

namespace urs::metrics {

class HttpEndpoint {
 public:
  // Binds `listen` and serves `metrics` (which must outlive this object). Throws
  // util::ConfigError naming --metrics-listen and the address when it cannot listen.
  HttpEndpoint(const util::Endpoint& listen, Metrics& metrics);
  ~HttpEndpoint();
  HttpEndpoint(const HttpEndpoint&) = delete;
  HttpEndpoint& operator=(const HttpEndpoint&) = delete;

  uint16_t port() const;  // the bound port (useful with port 0)

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace urs::metrics
