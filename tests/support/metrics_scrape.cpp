#include "metrics_scrape.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <regex>
#include <sstream>
#include <stdexcept>

namespace urs::test {

HttpResponse http_exchange(uint16_t port, const std::string& request, std::chrono::milliseconds timeout) {
  HttpResponse response;
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  if (fd < 0) return response;
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_port = htons(port);
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (connect(fd, reinterpret_cast<sockaddr*>(&address), sizeof address) != 0) {
    close(fd);
    return response;
  }
  size_t sent = 0;
  while (sent < request.size()) {
    const ssize_t n = send(fd, request.data() + sent, request.size() - sent, MSG_NOSIGNAL);
    if (n <= 0) break;
    sent += static_cast<size_t>(n);
  }
  std::string raw;
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  for (;;) {
    const auto left =
        std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now()).count();
    if (left <= 0) break;
    pollfd p{fd, POLLIN, 0};
    if (poll(&p, 1, static_cast<int>(left)) <= 0) break;
    char buffer[65536];
    const ssize_t n = recv(fd, buffer, sizeof buffer, 0);
    if (n <= 0) break;
    raw.append(buffer, static_cast<size_t>(n));
  }
  close(fd);
  const auto end = raw.find("\r\n\r\n");
  if (raw.compare(0, 9, "HTTP/1.1 ") != 0 || end == std::string::npos) return response;
  response.status = std::stoi(raw.substr(9, 3));
  response.head = raw.substr(0, end);
  response.body = raw.substr(end + 4);
  return response;
}

HttpResponse http_get(uint16_t port, const std::string& path) {
  return http_exchange(port, "GET " + path + " HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n");
}

namespace {

// Calls `each(value)` for every series `name` of `text` whose labels include `labels`.
template <typename Each>
void for_series(const std::string& text, const std::string& name, const std::map<std::string, std::string>& labels,
                Each each) {
  static const std::regex kLine(R"(^([a-zA-Z_:][a-zA-Z0-9_:]*)(\{(.*)\})? (\S+)$)");
  static const std::regex kLabel(R"re(([a-zA-Z_][a-zA-Z0-9_]*)="((?:[^"\\]|\\.)*)")re");
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) {
    std::smatch match;
    if (line.empty() || line[0] == '#' || !std::regex_match(line, match, kLine) || match[1] != name) continue;
    std::map<std::string, std::string> found;
    const std::string inside = match[3];
    for (auto it = std::sregex_iterator(inside.begin(), inside.end(), kLabel); it != std::sregex_iterator(); ++it) {
      found[(*it)[1]] = (*it)[2];
    }
    bool all = true;
    for (const auto& [key, value] : labels) {
      auto at = found.find(key);
      if (at == found.end() || at->second != value) all = false;
    }
    if (all) each(std::stod(match[4]));
  }
}

}  // namespace

std::optional<double> metric_value(const std::string& text, const std::string& name,
                                   const std::map<std::string, std::string>& labels) {
  std::optional<double> value;
  for_series(text, name, labels, [&](double v) {
    if (!value) value = v;
  });
  return value;
}

double metric_sum(const std::string& text, const std::string& name, const std::map<std::string, std::string>& labels) {
  double sum = 0;
  for_series(text, name, labels, [&](double v) { sum += v; });
  return sum;
}

std::optional<uint16_t> metrics_port_in_log(const std::string& log) {
  static const std::regex kServed(R"(metrics: serving /metrics, /healthz and /readyz on \S+:([0-9]+))");
  std::smatch match;
  if (!std::regex_search(log, match, kServed)) return std::nullopt;
  return static_cast<uint16_t>(std::stoi(match[1]));
}

CommandResult promtool_check_metrics(const std::string& text) {
  char path[] = "/tmp/urs-metrics-XXXXXX";
  const int fd = mkstemp(path);
  if (fd < 0) throw std::runtime_error("cannot make a temporary file for promtool");
  close(fd);
  std::ofstream(path) << text;
  auto result = run_command({"/bin/sh", "-c", std::string(URS_PROMTOOL) + " check metrics < " + path});
  std::remove(path);
  return result;
}

}  // namespace urs::test
