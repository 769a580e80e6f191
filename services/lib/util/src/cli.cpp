#include "urs/util/cli.hpp"

#include <signal.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>
#include <sys/resource.h>
#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <sstream>

#include "urs/util/log_format.hpp"

namespace urs::util {

void init_logging(const std::string& program, const std::string& level) {
  init_logging(LogOptions{program, level, "text", {}});
}

void init_logging(const LogOptions& options) {
  auto parsed = spdlog::level::from_str(options.level);
  // from_str maps unknown names to "off"; only accept "off" when it was asked for.
  if (parsed == spdlog::level::off && options.level != "off") {
    throw ConfigError("--log-level: unknown level '" + options.level + "' (expected " + kLogLevels + ")");
  }
  if (options.format != "text" && options.format != "json") {
    throw ConfigError("--log-format: unknown format '" + options.format + "' (expected " + kLogFormats + ")");
  }
  auto logger = spdlog::get(options.program);
  if (!logger) logger = spdlog::stderr_color_mt(options.program);
  logger->set_formatter(options.format == "json" ? json_log_formatter(options.program, options.space)
                                                 : text_log_formatter());
  logger->set_level(parsed);
  logger->flush_on(spdlog::level::warn);
  spdlog::set_default_logger(logger);
}

Endpoint parse_endpoint(const std::string& text, const std::string& what) {
  std::string host;
  std::string port_text;
  if (!text.empty() && text.front() == '[') {
    auto close = text.find(']');
    if (close == std::string::npos || close + 1 >= text.size() || text[close + 1] != ':') {
      throw ConfigError(what + ": '" + text + "' is not [IPV6]:PORT");
    }
    host = text.substr(1, close - 1);
    port_text = text.substr(close + 2);
  } else {
    auto colon = text.rfind(':');
    if (colon == std::string::npos || colon == 0) {
      throw ConfigError(what + ": '" + text + "' is not HOST:PORT");
    }
    host = text.substr(0, colon);
    port_text = text.substr(colon + 1);
  }
  if (port_text.empty() || port_text.size() > 5 || port_text.find_first_not_of("0123456789") != std::string::npos) {
    throw ConfigError(what + ": port '" + port_text + "' in '" + text + "' is not a number 0..65535");
  }
  unsigned long port = std::stoul(port_text);
  if (port > 65535) {
    throw ConfigError(what + ": port " + port_text + " in '" + text + "' is over 65535");
  }
  return Endpoint{host, static_cast<uint16_t>(port)};
}

std::string read_token_file(const std::string& path) {
  if (path.empty()) return {};
  std::ifstream in(path);
  if (!in) throw ConfigError("token file '" + path + "' cannot be read");
  std::stringstream buffer;
  buffer << in.rdbuf();
  return token_from_text(buffer.str(), path);
}

std::string token_from_text(std::string token, const std::string& path) {
  const char* ws = " \t\r\n";
  token.erase(0, token.find_first_not_of(ws));
  auto last = token.find_last_not_of(ws);
  token.erase(last == std::string::npos ? 0 : last + 1);
  if (token.empty()) throw ConfigError("token file '" + path + "' is empty");
  return token;
}

uint64_t raise_descriptor_limit() {
  rlimit limit{};
  if (getrlimit(RLIMIT_NOFILE, &limit) != 0) return 0;
  if (limit.rlim_cur < limit.rlim_max) {
    const rlim_t before = limit.rlim_cur;
    limit.rlim_cur = limit.rlim_max;
    if (setrlimit(RLIMIT_NOFILE, &limit) != 0) limit.rlim_cur = before;
  }
  return limit.rlim_cur == RLIM_INFINITY ? UINT64_MAX : static_cast<uint64_t>(limit.rlim_cur);
}

namespace {
sigset_t shutdown_set(bool with_reload) {
  sigset_t set;
  sigemptyset(&set);
  sigaddset(&set, SIGINT);
  sigaddset(&set, SIGTERM);
  if (with_reload) sigaddset(&set, SIGHUP);
  return set;
}
}  // namespace

void block_shutdown_signals(bool with_reload) {
  sigset_t set = shutdown_set(with_reload);
  pthread_sigmask(SIG_BLOCK, &set, nullptr);
  signal(SIGPIPE, SIG_IGN);
}

int wait_for_shutdown(const std::function<void()>& on_reload) {
  sigset_t set = shutdown_set(static_cast<bool>(on_reload));
  for (;;) {
    int sig = 0;
    sigwait(&set, &sig);
    if (sig != SIGHUP) return sig;
    on_reload();
  }
}

void write_file_atomically(const std::string& path, const std::string& content) {
  std::string tmp = path + ".tmp";
  {
    std::ofstream out(tmp, std::ios::trunc);
    if (!out) throw ConfigError("cannot write '" + tmp + "'");
    out << content;
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    throw ConfigError("cannot rename '" + tmp + "' to '" + path + "'");
  }
}

std::string host_name() {
  char buffer[256] = {};
  if (gethostname(buffer, sizeof(buffer) - 1) != 0 || buffer[0] == '\0') return "localhost";
  return buffer;
}

}  // namespace urs::util
