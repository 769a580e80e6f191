#include "urs/util/log_format.hpp"

#include <spdlog/details/fmt_helper.h>
#include <spdlog/pattern_formatter.h>

#include <chrono>
#include <ctime>

#include "urs/util/trace.hpp"

namespace urs::util {
namespace {

// %* in the text pattern: " trace=<id>" on the lines of a call, nothing on the others.
class TraceFlag final : public spdlog::custom_flag_formatter {
 public:
  void format(const spdlog::details::log_msg&, const std::tm&, spdlog::memory_buf_t& dest) override {
    const TraceContext* trace = current_trace();
    if (trace == nullptr) return;
    const std::string id = " trace=" + trace->trace_id_hex();
    dest.append(id.data(), id.data() + id.size());
  }
  std::unique_ptr<custom_flag_formatter> clone() const override { return std::make_unique<TraceFlag>(); }
};

void append(spdlog::memory_buf_t& dest, std::string_view text) { dest.append(text.data(), text.data() + text.size()); }

// The length of the valid UTF-8 sequence at text[i], or 0 if none starts there (RFC 3629:
// no overlong forms, no surrogates, nothing above U+10FFFF).
size_t utf8_length(std::string_view text, size_t i) {
  const auto byte = [&](size_t k) { return static_cast<unsigned char>(text[k]); };
  const unsigned char c = byte(i);
  size_t length = 0;
  unsigned char low = 0x80;
  unsigned char high = 0xBF;
  if (c >= 0xC2 && c <= 0xDF) {
    length = 2;
  } else if (c >= 0xE0 && c <= 0xEF) {
    length = 3;
    if (c == 0xE0) low = 0xA0;
    if (c == 0xED) high = 0x9F;
  } else if (c >= 0xF0 && c <= 0xF4) {
    length = 4;
    if (c == 0xF0) low = 0x90;
    if (c == 0xF4) high = 0x8F;
  } else {
    return 0;
  }
  if (i + length > text.size()) return 0;
  if (byte(i + 1) < low || byte(i + 1) > high) return 0;
  for (size_t k = 2; k < length; ++k) {
    if (byte(i + k) < 0x80 || byte(i + k) > 0xBF) return 0;
  }
  return length;
}

// `text` as a JSON string literal: RFC 8259 escapes, and U+FFFD for what is not UTF-8.
void append_json_string(spdlog::memory_buf_t& dest, std::string_view text) {
  static constexpr char kHex[] = "0123456789abcdef";
  dest.push_back('"');
  for (size_t i = 0; i < text.size();) {
    const auto c = static_cast<unsigned char>(text[i]);
    if (c == '"' || c == '\\') {
      dest.push_back('\\');
      dest.push_back(static_cast<char>(c));
    } else if (c == '\n') {
      append(dest, "\\n");
    } else if (c == '\t') {
      append(dest, "\\t");
    } else if (c == '\r') {
      append(dest, "\\r");
    } else if (c < 0x20) {
      const char escaped[] = {'\\', 'u', '0', '0', kHex[c >> 4], kHex[c & 15]};
      dest.append(escaped, escaped + sizeof escaped);
    } else if (c < 0x80) {
      dest.push_back(static_cast<char>(c));
    } else if (size_t length = utf8_length(text, i); length != 0) {
      append(dest, text.substr(i, length));
      i += length;
      continue;
    } else {
      append(dest, "\xEF\xBF\xBD");  // U+FFFD REPLACEMENT CHARACTER
    }
    ++i;
  }
  dest.push_back('"');
}

class JsonFormatter final : public spdlog::formatter {
 public:
  JsonFormatter(std::string program, std::string space) : program_(std::move(program)), space_(std::move(space)) {}

  void format(const spdlog::details::log_msg& msg, spdlog::memory_buf_t& dest) override {
    using std::chrono::system_clock;
    const auto since_epoch = msg.time.time_since_epoch();
    const auto seconds = std::chrono::duration_cast<std::chrono::seconds>(since_epoch);
    const auto millis = std::chrono::duration_cast<std::chrono::milliseconds>(since_epoch - seconds).count();
    const std::time_t t = seconds.count();
    std::tm utc{};
    gmtime_r(&t, &utc);
    char time[40];
    const size_t n = std::strftime(time, sizeof time, "%Y-%m-%dT%H:%M:%S", &utc);
    std::snprintf(time + n, sizeof time - n, ".%03dZ", static_cast<int>(millis));

    append(dest, "{\"time\":\"");
    append(dest, time);
    append(dest, "\",\"level\":\"");
    const auto level = spdlog::level::to_string_view(msg.level);
    append(dest, std::string_view(level.data(), level.size()));
    append(dest, "\",\"program\":");
    append_json_string(dest, program_);
    if (!space_.empty()) {
      append(dest, ",\"space\":");
      append_json_string(dest, space_);
    }
    if (const TraceContext* trace = current_trace()) {
      append(dest, ",\"trace_id\":\"");
      append(dest, trace->trace_id_hex());
      dest.push_back('"');
    }
    append(dest, ",\"message\":");
    append_json_string(dest, std::string_view(msg.payload.data(), msg.payload.size()));
    append(dest, "}\n");
  }

  std::unique_ptr<spdlog::formatter> clone() const override {
    return std::make_unique<JsonFormatter>(program_, space_);
  }

 private:
  const std::string program_;
  const std::string space_;
};

}  // namespace

std::unique_ptr<spdlog::formatter> text_log_formatter() {
  auto formatter = std::make_unique<spdlog::pattern_formatter>();
  formatter->add_flag<TraceFlag>('*').set_pattern("%Y-%m-%dT%H:%M:%S.%e %^%-5l%$ [%n]%* %v");
  return formatter;
}

std::unique_ptr<spdlog::formatter> json_log_formatter(std::string program, std::string space) {
  return std::make_unique<JsonFormatter>(std::move(program), std::move(space));
}

}  // namespace urs::util
