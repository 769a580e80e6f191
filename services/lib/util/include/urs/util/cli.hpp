#pragma once
// Pieces every URSLink program shares: logging set-up, endpoints, token files, shutdown signals.
// Each throws urs::util::ConfigError with a message naming the flag or file and the bad value.

#include <cstdint>
#include <functional>
#include <stdexcept>
#include <string>

#include "urs/util/error.hpp"  // ConfigError

namespace urs::util {

// Valid --log-level values, for help texts.
inline constexpr const char* kLogLevels = "trace|debug|info|warn|error|critical|off";

// Sets the default spdlog logger (stderr, "<program>" in every line) to `level`, text lines.
void init_logging(const std::string& program, const std::string& level);

// How a program logs: --log-level, --log-format (text|json: urs/util/log_format.hpp) and the space
// its JSON lines name (empty: none).
struct LogOptions {
  std::string program;
  std::string level = "info";
  std::string format = "text";
  std::string space;
};
// As above, in `options.format`; throws ConfigError naming --log-level or --log-format.
void init_logging(const LogOptions& options);

struct Endpoint {
  std::string host;
  uint16_t port = 0;
  std::string str() const { return host + ":" + std::to_string(port); }
};

// "HOST:PORT" (PORT 0..65535; "[::1]:80" for IPv6). `what` names the flag in error messages.
Endpoint parse_endpoint(const std::string& text, const std::string& what);

// The token in FILE (surrounding white space removed). Empty path gives "".
std::string read_token_file(const std::string& path);
// The token in `text`, the content of the token file `path` (surrounding white space removed);
// throws ConfigError if there is none.
std::string token_from_text(std::string text, const std::string& path);

// Raises this process's soft limit of open file descriptors (RLIMIT_NOFILE) to its hard limit
// (a server's connections each need one). Returns the soft limit now in force; never throws.
uint64_t raise_descriptor_limit();

// Blocks SIGINT/SIGTERM (and SIGHUP if `with_reload`) in the calling thread (call first in main,
// before threads start); wait_for_shutdown() then blocks until SIGINT or SIGTERM arrives and
// returns its number. With `on_reload`, each SIGHUP meanwhile runs it (on the waiting thread;
// block_shutdown_signals(true) must have been called).
void block_shutdown_signals(bool with_reload = false);
int wait_for_shutdown(const std::function<void()>& on_reload = {});

// This machine's host name ("localhost" if it cannot be read); names replicas and RT contexts.
std::string host_name();

// Writes `content` to `path` atomically (temp file + rename), e.g. the bound port for tests.
void write_file_atomically(const std::string& path, const std::string& content);

}  // namespace urs::util
