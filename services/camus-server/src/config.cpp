#include "urs/camus_server/config.hpp"

#include <spdlog/common.h>

#include <CLI/CLI.hpp>
#include <charconv>
#include <filesystem>

#include "urs/camus_server/registry.hpp"

namespace urs::camus_server {

namespace {

uint64_t parse_number(const std::string& flag, const std::string& text, uint64_t min, uint64_t max,
                      const std::string& what) {
  uint64_t value = 0;
  auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (text.empty() || ec != std::errc() || end != text.data() + text.size() || value < min || value > max) {
    throw util::ConfigError(flag + ": '" + text + "' is not " + what + " (" + std::to_string(min) + ".." +
                            std::to_string(max) + ")");
  }
  return value;
}

}  // namespace

std::optional<ServerConfig> parse_command_line(int argc, const char* const* argv, std::ostream& out) {
  CLI::App app{"CAMUS server: service registry, routing, events, context and tasks over Planet",
               "urs-camus-server"};
  std::string space;
  std::string listen;
  std::string token_file;
  std::string data_dir;
  std::string tasks_dir;
  std::string port_file;
  std::string heartbeat = "1000";
  std::string heartbeat_timeout = "3000";
  std::string default_deadline = "10000";
  std::string retention = "100000";
  std::string log_level = "info";
  app.add_option("--space", space, "name of this robot space (announced to clients)")->required();
  app.add_option("--listen", listen, "HOST:PORT to accept Planet connections on (port 0 = any free port)")->required();
  app.add_option("--token-file", token_file, "file holding the space's shared secret (clients must present it)");
  app.add_option("--data-dir", data_dir, "directory for the event log, context and tasks (default: in memory)");
  app.add_option("--tasks-dir", tasks_dir, "directory of task YAML files defined at start");
  app.add_option("--port-file", port_file, "write the bound port to this file once listening");
  app.add_option("--heartbeat-ms", heartbeat, "heartbeat interval announced to clients (default 1000)");
  app.add_option("--heartbeat-timeout-ms", heartbeat_timeout, "silence after which a peer is dropped (default 3000)");
  app.add_option("--default-deadline-ms", default_deadline, "deadline of calls that give none (default 10000)");
  app.add_option("--event-retention", retention, "events kept for resuming subscribers (default 100000)");
  app.add_option("--log-level", log_level, std::string("log level: ") + util::kLogLevels + " (default info)");
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp&) {
    out << app.help();
    return std::nullopt;
  } catch (const CLI::ParseError& e) {
    throw util::ConfigError(e.what());
  }

  ServerConfig config;
  if (auto why = service_name_problem(space); !why.empty()) {
    throw util::ConfigError("--space: '" + space + "' is not a valid space name: " + why);
  }
  config.space = space;
  config.listen = util::parse_endpoint(listen, "--listen");
  try {
    config.token = util::read_token_file(token_file);
  } catch (const util::ConfigError& e) {
    throw util::ConfigError(std::string("--token-file: ") + e.what());
  }
  config.heartbeat_ms =
      static_cast<uint32_t>(parse_number("--heartbeat-ms", heartbeat, 10, 3'600'000, "a number of milliseconds"));
  config.heartbeat_timeout_ms = static_cast<uint32_t>(
      parse_number("--heartbeat-timeout-ms", heartbeat_timeout, 10, 3'600'000, "a number of milliseconds"));
  if (config.heartbeat_timeout_ms <= config.heartbeat_ms) {
    throw util::ConfigError("--heartbeat-timeout-ms: '" + heartbeat_timeout +
                            "' must be longer than --heartbeat-ms (" + heartbeat + ")");
  }
  config.default_deadline_ms = static_cast<uint32_t>(
      parse_number("--default-deadline-ms", default_deadline, 1, 86'400'000, "a number of milliseconds"));
  config.event_retention = parse_number("--event-retention", retention, 1, 100'000'000, "a number of events");
  auto level = spdlog::level::from_str(log_level);
  if (level == spdlog::level::off && log_level != "off") {
    throw util::ConfigError("--log-level: '" + log_level + "' is not one of " + util::kLogLevels);
  }
  config.log_level = log_level;
  if (!data_dir.empty()) {
    std::error_code ec;
    std::filesystem::create_directories(data_dir, ec);
    if (ec || !std::filesystem::is_directory(data_dir)) {
      throw util::ConfigError("--data-dir: '" + data_dir + "' cannot be created: " +
                              (ec ? ec.message() : std::string("not a directory")));
    }
  }
  config.data_dir = data_dir;
  if (!tasks_dir.empty() && !std::filesystem::is_directory(tasks_dir)) {
    throw util::ConfigError("--tasks-dir: '" + tasks_dir + "' is not a directory");
  }
  config.tasks_dir = tasks_dir;
  config.port_file = port_file;
  return config;
}

}  // namespace urs::camus_server
