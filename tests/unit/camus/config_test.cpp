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

// Why the command line `args` is refused; "" if it is accepted.
std::string refusal(std::vector<const char*> args) {
  std::string error;
  return parse(std::move(args), &error) ? "" : error;
}

TEST(Config, ParsesEveryFlag) {
  TempDir dir;
  std::string data = dir.file("data");
  auto config = parse({"--space", "kr", "--listen", "127.0.0.1:0", "--data-dir", data.c_str(), "--heartbeat-ms", "200",
                       "--heartbeat-timeout-ms", "900", "--default-deadline-ms", "1500", "--event-retention", "50",
                       "--log-level", "debug", "--port-file", "p"});
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
  EXPECT_EQ(refusal({"--space", "kr", "--listen", "nowhere"}), "--listen: 'nowhere' is not HOST:PORT");
  EXPECT_EQ(refusal({"--space", "kr", "--listen", "h:1", "--default-deadline-ms", "0"}),
            "--default-deadline-ms: '0' is not a number of milliseconds (1..86400000)");
  EXPECT_EQ(refusal({"--space", "kr", "--listen", "h:1", "--heartbeat-ms", "500", "--heartbeat-timeout-ms", "400"}),
            "--heartbeat-timeout-ms: '400' must be longer than --heartbeat-ms (500)");
  EXPECT_EQ(refusal({"--space", "kr", "--listen", "h:1", "--event-retention", "-5"}),
            "--event-retention: '-5' is not a number of events (1..100000000)");
  EXPECT_EQ(refusal({"--space", "kr", "--listen", "h:1", "--tasks-dir", "/nonexistent/tasks"}),
            "--tasks-dir: '/nonexistent/tasks' is not a directory");
  EXPECT_EQ(refusal({"--listen", "h:1"}), "--space is required");
}

TEST(Config, CredentialsAndLimits) {
  auto config = parse({"--space",
                       "kr",
                       "--listen",
                       "h:1",
                       "--credentials",
                       "c.yaml",
                       "--token-file",
                       "t",
                       "--token-role",
                       "sam",
                       "--token-name",
                       "kr-shared",
                       "--max-topic-bytes",
                       "1024",
                       "--max-topic-levels",
                       "16",
                       "--max-subscriptions-per-session",
                       "10",
                       "--max-subscriptions",
                       "100",
                       "--max-pending-calls-per-session",
                       "5",
                       "--max-pending-calls",
                       "50",
                       "--max-deadline-ms",
                       "60000",
                       "--event-queue",
                       "7",
                       "--event-queue-per-session",
                       "3",
                       "--event-queue-bytes",
                       "100000"});
  ASSERT_TRUE(config);
  EXPECT_EQ(config->credentials.credentials_file, "c.yaml");
  EXPECT_EQ(config->credentials.token_file, "t");
  EXPECT_EQ(config->credentials.token_role, planet::SAM);
  EXPECT_EQ(config->credentials.token_name, "kr-shared");
  EXPECT_EQ(config->limits.max_topic_bytes, 1024u);
  EXPECT_EQ(config->limits.max_topic_levels, 16u);
  EXPECT_EQ(config->limits.max_subscriptions_per_session, 10u);
  EXPECT_EQ(config->limits.max_subscriptions, 100u);
  EXPECT_EQ(config->limits.max_pending_calls_per_session, 5u);
  EXPECT_EQ(config->limits.max_pending_calls, 50u);
  EXPECT_EQ(config->limits.max_deadline_ms, 60000u);
  EXPECT_EQ(config->limits.event_queue, 7u);
  EXPECT_EQ(config->limits.event_queue_per_session, 3u);
  EXPECT_EQ(config->limits.event_queue_bytes, 100000u);

  auto defaults = parse({"--space", "kr", "--listen", "h:1"});
  ASSERT_TRUE(defaults);
  EXPECT_FALSE(defaults->credentials.any());
  EXPECT_EQ(defaults->limits.max_topic_bytes, 512u);
  EXPECT_EQ(defaults->limits.max_subscriptions_per_session, 1000u);

  EXPECT_EQ(refusal({"--space", "kr", "--listen", "h:1", "--token-file", "t"}),
            "--token-file needs --token-role (client, sam or operator): the role of the one credential it holds");
  EXPECT_EQ(refusal({"--space", "kr", "--listen", "h:1", "--token-file", "t", "--token-role", "root"}),
            "--token-role: 'root' is not client, sam or operator");
  EXPECT_EQ(refusal({"--space", "kr", "--listen", "h:1", "--token-name", "camus-server"}),
            "--token-name: 'camus-server' is not valid: it is reserved for the server");
  EXPECT_EQ(refusal({"--space", "kr", "--listen", "h:1", "--max-topic-levels", "1"}),
            "--max-topic-levels: '1' is not a number of levels (2..1024)");
}

}  // namespace
}  // namespace urs::camus_server::test
