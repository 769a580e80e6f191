#pragma once
// The two formats of a program's log lines (init_logging, urs/util/cli.hpp), as spdlog formatters:
//
//  text  2026-03-01T10:00:00.123 info  [urs-sam] trace=4bf92f3577b34da6a3ce929d0e0e4736 message
//        (local time; "trace=..." only on the lines of a call, those logged inside a TraceScope)
//  json  {"time":"2026-03-01T09:00:00.123Z","level":"info","program":"urs-sam","space":"kr",
//         "trace_id":"4bf92f3577b34da6a3ce929d0e0e4736","message":"..."}
//        one object per line; time in UTC (RFC 3339, milliseconds); "space" only when the program
//        knows its space, "trace_id" only on the lines of a call; a message's bytes that are not
//        UTF-8 become U+FFFD, so every line is valid JSON.
//
// Threading: a formatter is used by its sink under the sink's lock; the trace id is the one of the
// thread that logs (spdlog's synchronous loggers format on it).

#include <spdlog/formatter.h>

#include <memory>
#include <string>

namespace urs::util {

// Valid --log-format values, for help texts.
inline constexpr const char* kLogFormats = "text|json";

std::unique_ptr<spdlog::formatter> text_log_formatter();
std::unique_ptr<spdlog::formatter> json_log_formatter(std::string program, std::string space);

}  // namespace urs::util
