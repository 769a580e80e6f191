#include "urs/camus_server/config.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <sstream>

#include "fakes.hpp"

namespace urs::camus_server::test {
namespace {

std::optional<ServerConfig> parse(std::vector<const char*> args, std::string* error = nullptr) {
  args.insert(args.begin(), "urs-camus-server");
  std::ostringstream out;
  try {
    return parse_command_line(static_cast<int>(args.size()), args.data(), out);
  } catch (const util::ConfigError& e) {
    if (error != nullptr) *error = e.what();
    return std::nullopt;
  }
}

TEST(Config, ParsesEveryFlag) {
  TempDir dir;
  std::string data = dir.file("data");
  auto config = parse({"--space", "kr", "--listen", "127.0.0.1:0", "--data-dir", data.c_str(), "--heartbeat-ms",
                       "200", "--heartbeat-timeout-ms", "900", "--default-deadline-ms", "1500", "--event-retention",
                       "50", "--log-level", "debug", "--port-file", "p"});
  ASSERT_TRUE(config);
  EXPECT_EQ(config->space, "kr");
  EXPECT_EQ(config->listen.port, 0);
  EXPECT_EQ(config->heartbeat_ms, 200u);
  EXPECT_EQ(config->heartbeat_timeout_ms, 900u);
  EXPECT_EQ(config->default_deadline_ms, 1500u);
  EXPECT_EQ(config->event_retention, 50u);
  EXPECT_TRUE(std::filesystem::is_directory(data));
}

TEST(Config, BadValuesNameTheFlag) {
  std::string error;
  EXPECT_FALSE(parse({"--space", "kr", "--listen", "nowhere"}, &error));
  EXPECT_EQ(error, "--listen: 'nowhere' is not HOST:PORT");
  EXPECT_FALSE(parse({"--space", "kr", "--listen", "h:1", "--default-deadline-ms", "0"}, &error));
  EXPECT_EQ(error, "--default-deadline-ms: '0' is not a number of milliseconds (1..86400000)");
  EXPECT_FALSE(parse({"--space", "kr", "--listen", "h:1", "--heartbeat-ms", "500", "--heartbeat-timeout-ms", "400"}, &error));
  EXPECT_EQ(error, "--heartbeat-timeout-ms: '400' must be longer than --heartbeat-ms (500)");
  EXPECT_FALSE(parse({"--space", "kr", "--listen", "h:1", "--event-retention", "-5"}, &error));
  EXPECT_EQ(error, "--event-retention: '-5' is not a number of events (1..100000000)");
  EXPECT_FALSE(parse({"--space", "kr", "--listen", "h:1", "--tasks-dir", "/nonexistent/tasks"}, &error));
  EXPECT_EQ(error, "--tasks-dir: '/nonexistent/tasks' is not a directory");
  EXPECT_FALSE(parse({"--listen", "h:1"}, &error));
  EXPECT_EQ(error, "--space is required");
}

}  // namespace
}  // namespace urs::camus_server::test
