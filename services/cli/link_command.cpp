#include "link_command.hpp"

#include <asio.hpp>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <map>
#include <optional>
#include <stdexcept>
#include <system_error>

#include "urs/util/cli.hpp"
#include "urs/util/json_text.hpp"

namespace urs::cli {

namespace {

constexpr std::size_t kMaxResponse = 4u << 20;  // bytes read from the endpoint at most
constexpr std::size_t kMaxSpaces = 1024;        // spaces shown at most (a bridge reports 64)

// The body of `GET /metrics` from `at`; throws std::runtime_error saying why there is none.
std::string get_metrics(const util::Endpoint& at, std::chrono::milliseconds timeout) {
  asio::io_context io;
  asio::ip::tcp::resolver resolver(io);
  asio::ip::tcp::socket socket(io);
  const std::string request = "GET /metrics HTTP/1.1\r\nHost: " + at.str() + "\r\nConnection: close\r\n\r\n";
  std::string response;
  std::error_code failure;
  bool done = false;
  auto finish = [&](std::error_code error) {
    failure = error;
    done = true;
  };
  resolver.async_resolve(at.host, std::to_string(at.port), [&](std::error_code error, auto endpoints) {
    if (error) return finish(error);
    asio::async_connect(socket, endpoints, [&](std::error_code error, const auto&) {
      if (error) return finish(error);
      asio::async_write(socket, asio::buffer(request), [&](std::error_code error, std::size_t) {
        if (error) return finish(error);
        asio::async_read(socket, asio::dynamic_buffer(response, kMaxResponse), [&](std::error_code error, std::size_t) {
          finish(error == asio::error::eof ? std::error_code() : error);
        });
      });
    });
  });
  io.run_for(timeout);
  if (!done)
    throw std::runtime_error("no answer from " + at.str() + " within " + std::to_string(timeout.count()) + " ms");
  if (failure) throw std::runtime_error(at.str() + ": " + failure.message());
  const auto head_end = response.find("\r\n\r\n");
  if (response.compare(0, 5, "HTTP/") != 0 || head_end == std::string::npos) {
    throw std::runtime_error(at.str() + " does not answer HTTP (is it a bridge's --metrics-listen address?)");
  }
  const auto space = response.find(' ');
  if (space == std::string::npos || response.compare(space + 1, 3, "200") != 0) {
    throw std::runtime_error(at.str() + " answered " + response.substr(0, response.find('\r')));
  }
  return response.substr(head_end + 4);
}

// One sample of the text format: its family's name, labels and value.
struct Sample {
  std::string name;
  std::map<std::string, std::string> labels;
  double value = 0;
};

// The sample on `line`, or nullopt for a comment, a blank line or anything it cannot read.
std::optional<Sample> parse_sample(const std::string& line) {
  if (line.empty() || line[0] == '#') return std::nullopt;
  Sample sample;
  std::size_t i = line.find_first_of("{ ");
  if (i == std::string::npos || i == 0) return std::nullopt;
  sample.name = line.substr(0, i);
  if (line[i] == '{') {
    ++i;
    while (i < line.size() && line[i] != '}') {
      const auto equals = line.find("=\"", i);
      if (equals == std::string::npos) return std::nullopt;
      const std::string key = line.substr(i, equals - i);
      std::string value;
      std::size_t j = equals + 2;
      for (; j < line.size() && line[j] != '"'; ++j) {
        if (line[j] == '\\' && j + 1 < line.size()) {
          ++j;
          value += line[j] == 'n' ? '\n' : line[j];
        } else {
          value += line[j];
        }
      }
      if (j >= line.size()) return std::nullopt;
      sample.labels[key] = std::move(value);
      i = j + 1;
      if (i < line.size() && line[i] == ',') ++i;
    }
    if (i >= line.size()) return std::nullopt;
    ++i;
  }
  while (i < line.size() && line[i] == ' ') ++i;
  const std::size_t end = line.find(' ', i);
  const std::string number = line.substr(i, end == std::string::npos ? std::string::npos : end - i);
  const auto [stop, error] = std::from_chars(number.data(), number.data() + number.size(), sample.value);
  if (error != std::errc() || stop != number.data() + number.size()) return std::nullopt;
  return sample;
}

// What the endpoint says of one other space.
struct SpaceLink {
  bool up = false;
  double reached_since = 0;  // Unix seconds; 0: not reached
  double participants = 0;
  double services = 0;
  double round_trips = 0;
  double round_trip_seconds = 0;
  double last_round_trip_seconds = 0;
  double sent_bytes = 0;                   // call payloads sent to it (requests, replies to its calls)
  double received_bytes = 0;               // and received from it
  double last_failure_at = 0;              // Unix seconds; 0: never
  std::map<std::string, double> failures;  // by status
};

std::map<std::string, SpaceLink> read_link(const std::string& text) {
  static const std::map<std::string, double SpaceLink::*> kFields{
      {"urslink_bridge_link_reached_since_timestamp_seconds", &SpaceLink::reached_since},
      {"urslink_bridge_link_participants", &SpaceLink::participants},
      {"urslink_bridge_link_catalog_entries", &SpaceLink::services},
      {"urslink_bridge_link_round_trips_total", &SpaceLink::round_trips},
      {"urslink_bridge_link_round_trip_seconds_total", &SpaceLink::round_trip_seconds},
      {"urslink_bridge_link_last_round_trip_seconds", &SpaceLink::last_round_trip_seconds},
      {"urslink_bridge_link_last_failure_timestamp_seconds", &SpaceLink::last_failure_at},
  };
  std::map<std::string, SpaceLink> spaces;
  std::size_t start = 0;
  while (start < text.size()) {
    std::size_t end = text.find('\n', start);
    if (end == std::string::npos) end = text.size();
    const std::optional<Sample> sample = parse_sample(text.substr(start, end - start));
    start = end + 1;
    if (!sample || sample->name.rfind("urslink_bridge_link_", 0) != 0 || !std::isfinite(sample->value)) continue;
    const auto space = sample->labels.find("space");
    if (space == sample->labels.end()) continue;
    if (spaces.size() >= kMaxSpaces && spaces.count(space->second) == 0) continue;
    if (sample->name == "urslink_bridge_link_up") {
      spaces[space->second].up = sample->value != 0;
    } else if (sample->name == "urslink_bridge_link_payload_bytes_total") {
      const auto direction = sample->labels.find("direction");
      if (direction == sample->labels.end()) continue;
      if (direction->second == "sent") spaces[space->second].sent_bytes = sample->value;
      if (direction->second == "received") spaces[space->second].received_bytes = sample->value;
    } else if (sample->name == "urslink_bridge_link_call_failures_total") {
      const auto status = sample->labels.find("status");
      if (status != sample->labels.end() && sample->value > 0)
        spaces[space->second].failures[status->second] = sample->value;
    } else if (const auto field = kFields.find(sample->name); field != kFields.end()) {
      spaces[space->second].*(field->second) = sample->value;
    }
  }
  return spaces;
}

std::string milliseconds(double seconds) {
  char text[32];
  std::snprintf(text, sizeof text, "%.1fms", seconds * 1000);
  return text;
}

std::string bytes(double value) {
  char text[32];
  if (value < 1024) {
    std::snprintf(text, sizeof text, "%.0fB", value);
  } else if (value < 1024 * 1024) {
    std::snprintf(text, sizeof text, "%.1fKiB", value / 1024);
  } else if (value < 1024.0 * 1024 * 1024) {
    std::snprintf(text, sizeof text, "%.1fMiB", value / (1024 * 1024));
  } else {
    std::snprintf(text, sizeof text, "%.1fGiB", value / (1024.0 * 1024 * 1024));
  }
  return text;
}

std::string number(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%.17g", value);
  return text;
}

}  // namespace

std::string ago(int64_t unix_seconds) {
  const int64_t now =
      std::chrono::duration_cast<std::chrono::seconds>(std::chrono::system_clock::now().time_since_epoch()).count();
  const int64_t seconds = std::max<int64_t>(now - unix_seconds, 0);
  if (seconds < 120) return std::to_string(seconds) + "s";
  if (seconds < 7200) return std::to_string(seconds / 60) + "m";
  return std::to_string(seconds / 3600) + "h";
}

int run_link_command(const std::string& address, bool json, std::chrono::milliseconds timeout) {
  std::map<std::string, SpaceLink> spaces;
  try {
    const util::Endpoint at = util::parse_endpoint(address, "BRIDGE");
    const std::string text = get_metrics(at, timeout);
    if (text.find("urslink_bridge_link_up") == std::string::npos) {
      throw std::runtime_error(at.str() + " reports no link to other spaces (a bridge without dds, or not a bridge)");
    }
    spaces = read_link(text);
  } catch (const std::exception& e) {
    std::cerr << "urs link: " << e.what() << "\n";
    return 1;
  }
  if (json) {
    std::string out = "{\"spaces\":[";
    for (const auto& [name, s] : spaces) {
      if (out.back() != '[') out += ",";
      out += "{\"space\":" + util::json_string(name) + ",\"state\":\"" + (s.up ? "up" : "lost") +
             "\",\"reached_since\":" + number(s.reached_since) + ",\"participants\":" + number(s.participants) +
             ",\"services\":" + number(s.services) + ",\"round_trips\":" + number(s.round_trips) +
             ",\"round_trip_seconds\":" + number(s.round_trip_seconds) +
             ",\"last_round_trip_seconds\":" + number(s.last_round_trip_seconds) +
             ",\"sent_bytes\":" + number(s.sent_bytes) + ",\"received_bytes\":" + number(s.received_bytes) +
             ",\"last_failure_at\":" + number(s.last_failure_at) + ",\"failures\":{";
      bool first = true;
      for (const auto& [status, count] : s.failures) {
        out += (first ? "" : ",") + util::json_string(status) + ":" + number(count);
        first = false;
      }
      out += "}}";
    }
    std::cout << out << "]}\n";
    return 0;
  }
  std::printf("%-16s %-12s %-6s %-9s %-8s %-9s %-9s %-10s %-10s %s\n", "SPACE", "STATE", "PEERS", "SERVICES", "CALLS",
              "RTT-LAST", "RTT-MEAN", "SENT", "RECEIVED", "LINK FAILURES");
  for (const auto& [name, s] : spaces) {
    const std::string state =
        s.up ? "up" + (s.reached_since > 0 ? " " + ago(static_cast<int64_t>(s.reached_since)) : std::string()) : "lost";
    std::string failures;
    double total = 0;
    for (const auto& [status, count] : s.failures) {
      failures += (failures.empty() ? "" : ", ") + status + " " + number(count);
      total += count;
    }
    failures = total == 0 ? "none"
                          : number(total) + " (" + failures + "), last " +
                                ago(static_cast<int64_t>(s.last_failure_at)) + " ago";
    std::printf("%-16s %-12s %-6s %-9s %-8s %-9s %-9s %-10s %-10s %s\n", name.c_str(), state.c_str(),
                number(s.participants).c_str(), number(s.services).c_str(), number(s.round_trips).c_str(),
                s.round_trips > 0 ? milliseconds(s.last_round_trip_seconds).c_str() : "-",
                s.round_trips > 0 ? milliseconds(s.round_trip_seconds / s.round_trips).c_str() : "-",
                bytes(s.sent_bytes).c_str(), bytes(s.received_bytes).c_str(), failures.c_str());
  }
  return 0;
}

}  // namespace urs::cli
