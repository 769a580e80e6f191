#pragma once
// Command line of urs-camus-server, validated once into an immutable struct.

#include <cstdint>
#include <optional>
#include <ostream>
#include <string>

#include "urs/util/cli.hpp"

namespace urs::camus_server {

struct ServerConfig {
  std::string space;
  util::Endpoint listen;
  std::string token;           // from --token-file; empty = no authentication
  std::string data_dir;        // empty = everything in memory (nothing survives a restart)
  std::string tasks_dir;       // empty = none
  std::string port_file;       // empty = none
  uint32_t heartbeat_ms = 1000;
  uint32_t heartbeat_timeout_ms = 3000;
  uint32_t default_deadline_ms = 10000;
  uint64_t event_retention = 100000;
  std::string log_level = "info";
};

// Parses and validates the command line. Throws util::ConfigError with one line naming the flag
// and the bad value. Returns nullopt when --help was asked for (help already written to `out`).
std::optional<ServerConfig> parse_command_line(int argc, const char* const* argv, std::ostream& out);

}  // namespace urs::camus_server
