#pragma once
// Reading a program's --metrics-listen endpoint in tests: HTTP GET over loopback, the value of one
// series in the Prometheus text format, and `promtool check metrics` on what was scraped.

#include <chrono>
#include <cstdint>
#include <map>
#include <optional>
#include <string>

#include "process.hpp"

namespace urs::test {

struct HttpResponse {
  int status = 0;  // 0: no answer
  std::string head;
  std::string body;
};

// Sends `request` (a whole HTTP request) to 127.0.0.1:`port` and reads until the server closes.
HttpResponse http_exchange(uint16_t port, const std::string& request,
                           std::chrono::milliseconds timeout = std::chrono::seconds(10));
// GET `path` over HTTP/1.1.
HttpResponse http_get(uint16_t port, const std::string& path);

// The value of the series `name` whose labels include every one of `labels` (the first such
// line of `text`, a /metrics body); nullopt when there is none.
std::optional<double> metric_value(const std::string& text, const std::string& name,
                                   const std::map<std::string, std::string>& labels = {});
// The sum over every series `name` whose labels include `labels`; 0 when there is none.
double metric_sum(const std::string& text, const std::string& name,
                  const std::map<std::string, std::string>& labels = {});

// The port a program's --metrics-listen endpoint bound, from its log line "metrics: serving ...
// on HOST:PORT"; nullopt until it is logged.
std::optional<uint16_t> metrics_port_in_log(const std::string& log);

// `promtool check metrics` (Debian's prometheus package) on `text`: exit code 0 and no output when
// it is clean.
CommandResult promtool_check_metrics(const std::string& text);

}  // namespace urs::test
