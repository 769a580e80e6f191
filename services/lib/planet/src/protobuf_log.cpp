// libprotobuf's own log (e.g. "Can't parse message of type ..." for a hostile frame) goes through
// spdlog, so that it obeys --log-level and is rate-limited like every other message a peer can
// cause. Installed when the library is loaded: every program that speaks Planet gets it.

#include <google/protobuf/stubs/logging.h>
#include <spdlog/spdlog.h>

#include <chrono>
#include <string>

#include "urs/util/rate_limit.hpp"

namespace urs::planet {
namespace {

void protobuf_log(google::protobuf::LogLevel level, const char* filename, int line, const std::string& message) {
  // Errors and warnings of libprotobuf describe input the codec refuses with a typed status
  // already: warn, at most 10 per 10 s.
  static util::RateLimiter limiter(10, std::chrono::seconds(10));
  spdlog::level::level_enum mapped = spdlog::level::debug;
  switch (level) {
    case google::protobuf::LOGLEVEL_INFO:
      mapped = spdlog::level::debug;
      break;
    case google::protobuf::LOGLEVEL_WARNING:
    case google::protobuf::LOGLEVEL_ERROR:
      mapped = spdlog::level::warn;
      break;
    case google::protobuf::LOGLEVEL_FATAL:
      mapped = spdlog::level::critical;
      break;
  }
  if (!spdlog::should_log(mapped)) return;
  uint64_t suppressed = 0;
  if (mapped != spdlog::level::critical && !limiter.allow("libprotobuf", suppressed)) return;
  spdlog::log(mapped, "libprotobuf {}:{}: {}{}", filename ? filename : "?", line, message,
              util::suppressed_note(suppressed));
}

struct InstallProtobufLogHandler {
  InstallProtobufLogHandler() { google::protobuf::SetLogHandler(&protobuf_log); }
} install_protobuf_log_handler;

}  // namespace
}  // namespace urs::planet
