// urs::util log formats: text lines carry the trace of a call, JSON lines are one valid object
// each with time, level, program, space and trace id.

#include "urs/util/log_format.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <spdlog/details/log_msg.h>

#include <regex>

#include "urs/util/cli.hpp"
#include "urs/util/trace.hpp"

namespace urs::util {
namespace {

using ::testing::HasSubstr;
using ::testing::MatchesRegex;
using ::testing::Not;

constexpr const char* kTrace = "00-4bf92f3577b34da6a3ce929d0e0e4736-00f067aa0ba902b7-01";

std::string format(spdlog::formatter& formatter, std::string_view message,
                   spdlog::level::level_enum level = spdlog::level::info) {
  spdlog::details::log_msg msg("urs-sam", level, spdlog::string_view_t(message.data(), message.size()));
  spdlog::memory_buf_t out;
  formatter.format(msg, out);
  return std::string(out.data(), out.size());
}

TEST(TextLog, NamesTheTraceOnTheLinesOfACallOnly) {
  auto formatter = text_log_formatter();
  EXPECT_THAT(format(*formatter, "hello"), MatchesRegex("[0-9T:.-]+ info  \\[urs-sam\\] hello\n"));
  TraceScope scope(*TraceContext::parse(kTrace));
  EXPECT_THAT(format(*formatter, "hello"),
              MatchesRegex("[0-9T:.-]+ info  \\[urs-sam\\] trace=4bf92f3577b34da6a3ce929d0e0e4736 hello\n"));
}

TEST(JsonLog, OneObjectPerLineWithTimeLevelProgramSpaceAndTrace) {
  auto formatter = json_log_formatter("urs-sam", "kr");
  EXPECT_THAT(format(*formatter, "registered service diag", spdlog::level::warn),
              MatchesRegex("\\{\"time\":\"[0-9]{4}-[0-9]{2}-[0-9]{2}T[0-9]{2}:[0-9]{2}:[0-9]{2}\\.[0-9]{3}Z\","
                           "\"level\":\"warning\",\"program\":\"urs-sam\",\"space\":\"kr\","
                           "\"message\":\"registered service diag\"\\}\n"));
  TraceScope scope(*TraceContext::parse(kTrace));
  EXPECT_THAT(format(*formatter, "call"),
              HasSubstr(",\"trace_id\":\"4bf92f3577b34da6a3ce929d0e0e4736\",\"message\":\"call\"}\n"));
}

TEST(JsonLog, WithoutASpaceLeavesItOut) {
  auto formatter = json_log_formatter("urs", "");
  EXPECT_THAT(format(*formatter, "x"), Not(HasSubstr("space")));
}

TEST(JsonLog, EscapesAndReplacesWhatIsNotUtf8) {
  auto formatter = json_log_formatter("p", "s");
  const std::string line = format(*formatter, "a\"b\\c\nd\x01 caf\xc3\xa9 \xff\xc3 \xed\xa0\x80 end");
  EXPECT_THAT(line, HasSubstr("\"message\":\"a\\\"b\\\\c\\nd\\u0001 caf\xc3\xa9 \xef\xbf\xbd\xef\xbf\xbd "
                              "\xef\xbf\xbd\xef\xbf\xbd\xef\xbf\xbd end\"}"));
  EXPECT_EQ(line.find('\n'), line.size() - 1);  // one line
}

TEST(Logging, UnknownFormatIsRefusedNamingTheFlag) {
  try {
    init_logging(LogOptions{"t", "info", "xml", ""});
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_STREQ(e.what(), "--log-format: unknown format 'xml' (expected text|json)");
  }
}

}  // namespace
}  // namespace urs::util
