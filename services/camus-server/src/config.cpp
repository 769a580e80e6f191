#include "urs/camus_server/config.hpp"

#include <spdlog/common.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <charconv>
#include <filesystem>
#include <set>
#include <vector>

#include "urs/camus_server/registry.hpp"
#include "urs/metrics/flags.hpp"
#include "urs/util/program_flags.hpp"

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

// A limit per credential left at its default follows the limits around it: at most its
// server-wide limit, at least its per-session limit. Then a limit per credential above its
// server-wide limit, or per session above per credential, is a mistake: every one is reported at
// once. `given` says which flags were given.
void check_shares(SemanticLimits& limits, const std::set<std::string>& given) {
  struct Fit {
    const char* flag;
    uint64_t SemanticLimits::*field;
    uint64_t SemanticLimits::*at_least;
    uint64_t SemanticLimits::*at_most;
  };
  const Fit fits[] = {
      {"--max-subscriptions-per-credential", &SemanticLimits::max_subscriptions_per_credential,
       &SemanticLimits::max_subscriptions_per_session, &SemanticLimits::max_subscriptions},
      {"--max-pending-calls-per-credential", &SemanticLimits::max_pending_calls_per_credential,
       &SemanticLimits::max_pending_calls_per_session, &SemanticLimits::max_pending_calls},
      {"--event-queue-per-credential", &SemanticLimits::event_queue_per_credential,
       &SemanticLimits::event_queue_per_session, &SemanticLimits::event_queue},
      {"--event-queue-bytes-per-credential", &SemanticLimits::event_queue_bytes_per_credential, nullptr,
       &SemanticLimits::event_queue_bytes},
      {"--max-buffered-bytes-per-credential", &SemanticLimits::max_buffered_bytes_per_credential,
       &SemanticLimits::max_reassembly_bytes, &SemanticLimits::max_buffered_bytes},
      {"--max-sessions-per-credential", &SemanticLimits::max_sessions_per_credential, nullptr,
       &SemanticLimits::max_connections},
      {"--max-resumable-sessions-per-credential", &SemanticLimits::max_resumable_sessions_per_credential, nullptr,
       &SemanticLimits::max_resumable_sessions},
  };
  for (const Fit& fit : fits) {
    if (given.count(fit.flag) != 0) continue;
    uint64_t& value = limits.*fit.field;
    if (fit.at_least != nullptr) value = std::max(value, limits.*fit.at_least);
    if (fit.field == &SemanticLimits::max_buffered_bytes_per_credential) {
      value = std::max(value, limits.max_send_queue_bytes);
    }
    value = std::min(value, limits.*fit.at_most);
  }
  struct Pair {
    const char* part_flag;
    uint64_t part;
    const char* whole_flag;
    uint64_t whole;
  };
  const Pair pairs[] = {
      {"--max-subscriptions-per-session", limits.max_subscriptions_per_session, "--max-subscriptions-per-credential",
       limits.max_subscriptions_per_credential},
      {"--max-subscriptions-per-credential", limits.max_subscriptions_per_credential, "--max-subscriptions",
       limits.max_subscriptions},
      {"--max-pending-calls-per-session", limits.max_pending_calls_per_session, "--max-pending-calls-per-credential",
       limits.max_pending_calls_per_credential},
      {"--max-pending-calls-per-credential", limits.max_pending_calls_per_credential, "--max-pending-calls",
       limits.max_pending_calls},
      {"--event-queue-per-session", limits.event_queue_per_session, "--event-queue-per-credential",
       limits.event_queue_per_credential},
      {"--event-queue-per-credential", limits.event_queue_per_credential, "--event-queue", limits.event_queue},
      {"--event-queue-bytes-per-credential", limits.event_queue_bytes_per_credential, "--event-queue-bytes",
       limits.event_queue_bytes},
      {"--max-reassembly-bytes", limits.max_reassembly_bytes, "--max-buffered-bytes-per-credential",
       limits.max_buffered_bytes_per_credential},
      {"--max-message-bytes", limits.max_message_bytes, "--max-reassembly-bytes", limits.max_reassembly_bytes},
      {"--max-send-queue-bytes", limits.max_send_queue_bytes, "--max-buffered-bytes-per-credential",
       limits.max_buffered_bytes_per_credential},
      {"--max-buffered-bytes-per-credential", limits.max_buffered_bytes_per_credential, "--max-buffered-bytes",
       limits.max_buffered_bytes},
      {"--max-sessions-per-credential", limits.max_sessions_per_credential, "--max-connections",
       limits.max_connections},
      {"--max-resumable-sessions-per-credential", limits.max_resumable_sessions_per_credential,
       "--max-resumable-sessions", limits.max_resumable_sessions},
  };
  std::vector<std::string> errors;
  for (const Pair& pair : pairs) {
    if (pair.part > pair.whole) {
      errors.push_back(std::string(pair.part_flag) + ": " + std::to_string(pair.part) + " is above " + pair.whole_flag +
                       " (" + std::to_string(pair.whole) + ")");
    }
  }
  if (errors.empty()) return;
  std::string message = errors.front();
  for (size_t i = 1; i < errors.size(); ++i) message += "; " + errors[i];
  throw util::ConfigError(message);
}

}  // namespace

std::optional<ServerConfig> parse_command_line(int argc, const char* const* argv, std::ostream& out) {
  CLI::App app{"CAMUS server: service registry, routing, events, context and tasks over Planet", "urs-camus-server"};
  std::string space;
  std::string listen;
  std::string token_file;
  std::string token_name = "space";
  std::string token_role;
  std::string credentials_file;
  std::string data_dir;
  std::string tasks_dir;
  std::string port_file;
  std::string heartbeat = "1000";
  std::string heartbeat_timeout = "3000";
  std::string default_deadline = "10000";
  std::string retention = "100000";
  std::string log_level = "info";
  // The server's semantic limits, by flag: their text, then the field each fills.
  const SemanticLimits defaults;
  struct LimitFlag {
    const char* flag;
    const char* help;
    uint64_t SemanticLimits::*field;
    uint64_t min;
    uint64_t max;
    const char* what;
    std::string text;
  };
  std::vector<LimitFlag> limit_flags = {
      {"--max-topic-bytes", "longest topic or pattern in bytes", &SemanticLimits::max_topic_bytes, 16, 65536,
       "a number of bytes", ""},
      {"--max-topic-levels", "most levels of a topic or pattern", &SemanticLimits::max_topic_levels, 2, 1024,
       "a number of levels", ""},
      {"--max-subscriptions-per-session", "subscriptions one connection may hold",
       &SemanticLimits::max_subscriptions_per_session, 1, 1'000'000, "a number", ""},
      {"--max-subscriptions-per-credential", "subscriptions all connections of one credential may hold",
       &SemanticLimits::max_subscriptions_per_credential, 1, 10'000'000, "a number", ""},
      {"--max-subscriptions", "subscriptions of all connections together", &SemanticLimits::max_subscriptions, 1,
       10'000'000, "a number", ""},
      {"--max-pending-calls-per-session", "calls one connection may have waiting for a reply",
       &SemanticLimits::max_pending_calls_per_session, 1, 1'000'000, "a number", ""},
      {"--max-pending-calls-per-credential", "calls all connections of one credential may have waiting",
       &SemanticLimits::max_pending_calls_per_credential, 1, 10'000'000, "a number", ""},
      {"--max-pending-calls", "calls waiting for a reply, server-wide", &SemanticLimits::max_pending_calls, 1,
       10'000'000, "a number", ""},
      {"--max-deadline-ms", "largest deadline_ms a call may ask for", &SemanticLimits::max_deadline_ms, 1,
       uint64_t{1} << 40, "a number of milliseconds", ""},
      {"--event-queue", "publishes and subscribes waiting for the event bus before RESOURCE_EXHAUSTED",
       &SemanticLimits::event_queue, 1, 10'000'000, "a number", ""},
      {"--event-queue-per-credential", "of those, from one credential", &SemanticLimits::event_queue_per_credential, 1,
       10'000'000, "a number", ""},
      {"--event-queue-per-session", "of those, from one session", &SemanticLimits::event_queue_per_session, 1,
       10'000'000, "a number", ""},
      {"--event-queue-bytes", "bytes of those", &SemanticLimits::event_queue_bytes, 65536, uint64_t{1} << 40,
       "a number of bytes", ""},
      {"--event-queue-bytes-per-credential", "of those bytes, from one credential",
       &SemanticLimits::event_queue_bytes_per_credential, 65536, uint64_t{1} << 40, "a number of bytes", ""},
      {"--max-hello-bytes", "largest frame accepted before the handshake (the Hello; no chunks)",
       &SemanticLimits::max_hello_bytes, 512, 65536, "a number of bytes", ""},
      {"--max-message-bytes", "largest message a peer may send (chunked), announced in Welcome",
       &SemanticLimits::max_message_bytes, 65536, (uint64_t{1} << 31) - 1, "a number of bytes", ""},
      {"--max-reassembly-bytes", "per session: buffers of chunked messages in progress",
       &SemanticLimits::max_reassembly_bytes, 1 << 20, uint64_t{1} << 40, "a number of bytes", ""},
      {"--max-send-queue-bytes", "per session: frames waiting for a peer that reads slowly (more: the session closes)",
       &SemanticLimits::max_send_queue_bytes, 1 << 20, uint64_t{1} << 40, "a number of bytes", ""},
      {"--max-buffered-bytes", "all sessions: reassembly buffers and send queues together",
       &SemanticLimits::max_buffered_bytes, 1 << 20, uint64_t{1} << 44, "a number of bytes", ""},
      {"--max-buffered-bytes-per-credential", "of those, the sessions of one credential",
       &SemanticLimits::max_buffered_bytes_per_credential, 1 << 20, uint64_t{1} << 44, "a number of bytes", ""},
      {"--max-connections",
       "open connections, handshaking ones included (lowered at start to what the file descriptor limit allows)",
       &SemanticLimits::max_connections, 1, 1'000'000, "a number", ""},
      {"--max-connections-per-address", "of those, from one source address",
       &SemanticLimits::max_connections_per_address, 1, 1'000'000, "a number", ""},
      {"--max-sessions-per-credential", "open sessions of one credential", &SemanticLimits::max_sessions_per_credential,
       1, 1'000'000, "a number", ""},
      {"--max-resumable-sessions", "closed sessions kept resumable", &SemanticLimits::max_resumable_sessions, 1,
       10'000'000, "a number", ""},
      {"--max-resumable-sessions-per-credential", "of those, of one credential",
       &SemanticLimits::max_resumable_sessions_per_credential, 1, 10'000'000, "a number", ""},
      {"--reserved-percent",
       "percent of every server-wide limit that client credentials cannot use: kept for sam and operator sessions "
       "and the server's own work",
       &SemanticLimits::reserved_percent, 0, 90, "a percentage", ""},
  };
  for (auto& limit : limit_flags) {
    limit.text = std::to_string(defaults.*limit.field);
    app.add_option(limit.flag, limit.text, std::string(limit.help) + " (default " + limit.text + ")");
  }
  app.add_option("--space", space, "name of this robot space (announced to clients)")->required();
  app.add_option("--listen", listen, "HOST:PORT to accept Planet connections on (port 0 = any free port)")->required();
  app.add_option("--credentials", credentials_file,
                 "YAML file of named credentials (name, role, token_sha256 | token_file, certificate); "
                 "re-read on SIGHUP");
  app.add_option("--token-file", token_file, "file holding one token that clients may present (with --token-role)");
  app.add_option("--token-name", token_name, "name the --token-file credential authenticates as (default space)");
  app.add_option("--token-role", token_role, "role of the --token-file credential: client, sam or operator");
  app.add_option("--data-dir", data_dir, "directory for the event log, context and tasks (default: in memory)");
  app.add_option("--tasks-dir", tasks_dir, "directory of task YAML files defined at start");
  app.add_option("--port-file", port_file, "write the bound port to this file once listening");
  app.add_option("--heartbeat-ms", heartbeat, "heartbeat interval announced to clients (default 1000)");
  app.add_option("--heartbeat-timeout-ms", heartbeat_timeout, "silence after which a peer is dropped (default 3000)");
  app.add_option("--default-deadline-ms", default_deadline, "deadline of calls that give none (default 10000)");
  app.add_option("--event-retention", retention, "events kept for resuming subscribers (default 100000)");
  app.add_option("--log-level", log_level, std::string("log level: ") + util::kLogLevels + " (default info)");
  std::string log_format = "text";
  util::add_log_format_flag(app, log_format);
  std::string metrics_listen;
  metrics::add_metrics_flag(app, metrics_listen);
  util::TlsConfig tls;
  util::add_tls_server_flags(app, tls);
  bool allow_plaintext_tokens = false;
  app.add_flag("--allow-plaintext-tokens", allow_plaintext_tokens,
               "accept tokens over plain TCP from any address (default: from loopback only; use TLS instead)");
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
  config.credentials.credentials_file = credentials_file;
  config.credentials.token_file = token_file;
  config.credentials.token_name = token_name;
  if (!token_role.empty()) {
    config.credentials.token_role = parse_role(token_role);
    if (config.credentials.token_role == planet::ROLE_UNSPECIFIED) {
      throw util::ConfigError("--token-role: '" + token_role + "' is not client, sam or operator");
    }
  }
  if (!token_file.empty() && token_role.empty()) {
    throw util::ConfigError(
        "--token-file needs --token-role (client, sam or operator): the role of the one "
        "credential it holds");
  }
  if (auto why = planet::Credentials::name_problem(token_name); !why.empty()) {
    throw util::ConfigError("--token-name: '" + token_name + "' is not valid: " + why);
  }
  for (const auto& limit : limit_flags) {
    config.limits.*limit.field = parse_number(limit.flag, limit.text, limit.min, limit.max, limit.what);
  }
  std::set<std::string> given;
  for (const auto& limit : limit_flags) {
    if (app.count(limit.flag) > 0) given.insert(limit.flag);
  }
  check_shares(config.limits, given);
  config.heartbeat_ms =
      static_cast<uint32_t>(parse_number("--heartbeat-ms", heartbeat, 10, 3'600'000, "a number of milliseconds"));
  config.heartbeat_timeout_ms = static_cast<uint32_t>(
      parse_number("--heartbeat-timeout-ms", heartbeat_timeout, 10, 3'600'000, "a number of milliseconds"));
  if (config.heartbeat_timeout_ms <= config.heartbeat_ms) {
    throw util::ConfigError("--heartbeat-timeout-ms: '" + heartbeat_timeout + "' must be longer than --heartbeat-ms (" +
                            heartbeat + ")");
  }
  config.default_deadline_ms = static_cast<uint32_t>(
      parse_number("--default-deadline-ms", default_deadline, 1, 86'400'000, "a number of milliseconds"));
  config.event_retention = parse_number("--event-retention", retention, 1, 100'000'000, "a number of events");
  auto level = spdlog::level::from_str(log_level);
  if (level == spdlog::level::off && log_level != "off") {
    throw util::ConfigError("--log-level: '" + log_level + "' is not one of " + util::kLogLevels);
  }
  config.log_level = log_level;
  if (log_format != "text" && log_format != "json") {
    throw util::ConfigError("--log-format: '" + log_format + "' is not one of " + util::kLogFormats);
  }
  config.log_format = log_format;
  if (!metrics_listen.empty()) util::parse_endpoint(metrics_listen, "--metrics-listen");
  config.metrics_listen = metrics_listen;
  if (!data_dir.empty()) {
    std::error_code ec;
    std::filesystem::create_directories(data_dir, ec);
    if (ec || !std::filesystem::is_directory(data_dir)) {
      throw util::ConfigError("--data-dir: '" + data_dir +
                              "' cannot be created: " + (ec ? ec.message() : std::string("not a directory")));
    }
  }
  config.data_dir = data_dir;
  if (!tasks_dir.empty() && !std::filesystem::is_directory(tasks_dir)) {
    throw util::ConfigError("--tasks-dir: '" + tasks_dir + "' is not a directory");
  }
  config.tasks_dir = tasks_dir;
  config.port_file = port_file;
  util::check_tls_server(tls);
  config.tls = tls;
  config.allow_plaintext_tokens = allow_plaintext_tokens;
  return config;
}

}  // namespace urs::camus_server
