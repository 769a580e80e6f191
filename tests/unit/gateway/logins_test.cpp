// Logins in a space without a CAMUS server: the gateway compares the credential itself.
// (Against a real CAMUS server: tests/integration/gateway.)
#include "urs/gateway/logins.hpp"

#include <gtest/gtest.h>
#include <spdlog/sinks/ostream_sink.h>
#include <spdlog/spdlog.h>

#include <sstream>

using urs::gateway::LoginOptions;
using urs::gateway::Logins;
using urs::gateway::Role;

namespace {
LoginOptions options() {
  LoginOptions o;
  o.space_token = "space-secret";
  o.viewer_token = "viewer-secret";
  o.max_logins = 3;
  o.max_failures_per_minute = 4;
  return o;
}
}  // namespace

TEST(Logins, TheSpaceCredentialOperatesTheViewerOneSees) {
  Logins logins(options());
  auto op = logins.login("space-secret");
  ASSERT_TRUE(op.login) << op.error;
  EXPECT_EQ(op.login->role, Role::operator_);
  EXPECT_EQ(op.login->id.size(), 32u);
  auto viewer = logins.login("viewer-secret");
  ASSERT_TRUE(viewer.login);
  EXPECT_EQ(viewer.login->role, Role::viewer);
  EXPECT_NE(op.login->id, viewer.login->id);
  EXPECT_EQ(logins.find(op.login->id), op.login);
  EXPECT_TRUE(logins.logout(op.login->id));
  EXPECT_EQ(logins.find(op.login->id), nullptr);
  EXPECT_FALSE(logins.logout(op.login->id));
}

// The session id is the login's secret: the log names a login by its number, and shows no part of
// the id (nor does the peer name a login's CAMUS session carries: tests/integration/gateway).
TEST(Logins, TheLogNamesALoginByItsNumberNeverByItsSecret) {
  std::ostringstream logged;
  const auto before = spdlog::default_logger();
  spdlog::set_default_logger(
      std::make_shared<spdlog::logger>("test", std::make_shared<spdlog::sinks::ostream_sink_mt>(logged)));
  Logins logins(options());
  auto first = logins.login("space-secret");
  auto second = logins.login("viewer-secret");
  spdlog::set_default_logger(before);
  ASSERT_TRUE(first.login && second.login);
  EXPECT_EQ(first.login->number, 1u);
  EXPECT_EQ(second.login->number, 2u);
  EXPECT_NE(logged.str().find("login #1 as operator"), std::string::npos) << logged.str();
  EXPECT_NE(logged.str().find("login #2 as viewer"), std::string::npos) << logged.str();
  for (const auto& id : {first.login->id, second.login->id}) {
    EXPECT_EQ(logged.str().find(id.substr(0, 8)), std::string::npos) << logged.str();
  }
}

TEST(Logins, WrongCredentialsAreRefusedAndThenRateLimited) {
  Logins logins(options());
  for (const char* wrong : {"space-secreT", "", "space-secret ", "x"}) {
    auto refused = logins.login(wrong);
    EXPECT_FALSE(refused.login);
    EXPECT_EQ(refused.http_status, 401) << wrong;
  }
  auto limited = logins.login("space-secret");  // right, but after 4 failures in a minute
  EXPECT_FALSE(limited.login);
  EXPECT_EQ(limited.http_status, 429);
}

TEST(Logins, ReadOnlyMakesEveryLoginAViewer) {
  auto o = options();
  o.read_only = true;
  Logins logins(o);
  auto login = logins.login("space-secret");
  ASSERT_TRUE(login.login);
  EXPECT_EQ(login.login->role, Role::viewer);
}

TEST(Logins, BoundedAndIdleLoginsEnd) {
  auto o = options();
  o.idle = std::chrono::seconds(0);
  Logins idle(o);
  auto gone = idle.login("space-secret");
  ASSERT_TRUE(gone.login);
  const auto made = std::chrono::steady_clock::now();
  while (std::chrono::steady_clock::now() == made) {
  }  // any time at all is past an idle time of 0
  EXPECT_EQ(idle.find(gone.login->id), nullptr);

  Logins logins(options());
  for (int i = 0; i < 3; ++i) ASSERT_TRUE(logins.login("space-secret").login);
  auto full = logins.login("space-secret");
  EXPECT_FALSE(full.login);
  EXPECT_EQ(full.http_status, 503);
  EXPECT_EQ(logins.size(), 3u);
}

TEST(Logins, NoSpaceCredentialMeansNoOperator) {
  Logins logins(LoginOptions{});
  EXPECT_EQ(logins.login("anything").http_status, 401);
}

TEST(Logins, SameSecret) {
  EXPECT_TRUE(urs::gateway::same_secret("abc", "abc"));
  EXPECT_FALSE(urs::gateway::same_secret("abc", "abd"));
  EXPECT_FALSE(urs::gateway::same_secret("abc", "abcd"));
}

// With a CAMUS server, the role is the one the server gives the credential (its Welcome): only
// an operator's credential operates; a client's or a SAM's sees; read-only overrides.
TEST(Logins, OnlyTheServersOperatorsOperate) {
  using urs::gateway::role_for;
  EXPECT_EQ(role_for(urs::planet::OPERATOR, false), Role::operator_);
  EXPECT_EQ(role_for(urs::planet::SAM, false), Role::viewer);
  EXPECT_EQ(role_for(urs::planet::CLIENT, false), Role::viewer);
  EXPECT_EQ(role_for(urs::planet::ROLE_UNSPECIFIED, false), Role::viewer);
  EXPECT_EQ(role_for(urs::planet::OPERATOR, true), Role::viewer);
}
