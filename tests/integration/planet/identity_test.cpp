// Who a Planet session speaks for: credentials with roles, server-issued session secrets that
// resume a session (and only with the same credential), peer names for display only, secrets
// never in a log, and credentials swapped at run time.

#include <gtest/gtest.h>
#include <spdlog/sinks/ostream_sink.h>
#include <spdlog/spdlog.h>

#include <regex>
#include <sstream>

#include "support.hpp"
#include "urs/planet/client.hpp"
#include "urs/planet/credentials.hpp"
#include "urs/planet/server.hpp"

namespace urs::planet::testing {
namespace {

std::shared_ptr<const Credentials> credentials(std::vector<std::tuple<std::string, Role, std::string>> list) {
  std::vector<Credential> out;
  for (auto& [name, role, token] : list) out.push_back(Credential{name, role, util::sha256_hex(token), ""});
  return std::make_shared<const Credentials>(std::move(out));
}

std::shared_ptr<const Credentials> team() {
  return credentials(
      {{"alice", OPERATOR, "alice-token"}, {"robot1", SAM, "robot1-token"}, {"viewer", CLIENT, "viewer-token"}});
}

// A server with the team's credentials and a recording handler.
class PlanetIdentity : public ::testing::Test {
 protected:
  PlanetIdentity() {
    ServerOptions options = server_options();
    options.authenticator = team();
    server_ = std::make_unique<Server>(options, handler);
    server_->start();
  }
  uint16_t port() const { return server_->port(); }
  // Waits until the handler has seen `n` sessions open (on_open runs after Welcome is queued, on
  // any I/O thread: a client can hold its Welcome before the server's handler has run).
  void wait_opened(size_t n) {
    ASSERT_TRUE(eventually([&] { return handler.identities().size() >= n; })) << handler.identities().size();
  }

  TestHandler handler;
  std::unique_ptr<Server> server_;
};

Welcome welcome_of(RawPeer& raw) {
  auto frame = raw.read_non_ping();
  if (!frame || !frame->has_welcome()) {
    ADD_FAILURE() << "no Welcome: " << (frame ? frame->ShortDebugString() : std::string("nothing"));
    return {};
  }
  return frame->welcome();
}

TEST_F(PlanetIdentity, WelcomeNamesTheCredentialAndIssuesASecret) {
  RawPeer raw(port());
  raw.send_hello(1, "robot1-token", "camus-server-lookalike", "", SAM);
  const Welcome welcome = welcome_of(raw);
  EXPECT_EQ(welcome.identity(), "robot1");
  EXPECT_EQ(welcome.role(), SAM);
  EXPECT_TRUE(std::regex_match(welcome.session_secret(), std::regex("[0-9a-f]{64}"))) << welcome.session_secret();
  ASSERT_TRUE(eventually([&] { return handler.identities().size() == 1; }));
  EXPECT_EQ(handler.identities()[0].name, "robot1");
  EXPECT_EQ(handler.opened()[0].peer_name(), "camus-server-lookalike");  // display only
}

TEST_F(PlanetIdentity, TheSecretResumesTheSessionOnlyWithTheSameCredential) {
  RawPeer first(port());
  first.send_hello(1, "robot1-token", "sam", "", SAM);
  const Welcome one = welcome_of(first);
  wait_opened(1);

  // Another credential presenting the secret gets a session of its own.
  RawPeer stranger(port());
  stranger.send_hello(1, "alice-token", "thief", one.session_secret(), SAM);
  const Welcome other = welcome_of(stranger);
  EXPECT_NE(other.session_secret(), one.session_secret());
  wait_opened(2);
  // A secret the server never issued: a new session too.
  RawPeer guesser(port());
  guesser.send_hello(1, "robot1-token", "guess", std::string(64, '0'), SAM);
  const Welcome guessed = welcome_of(guesser);
  EXPECT_NE(guessed.session_secret(), one.session_secret());
  wait_opened(3);

  // The same credential with the secret resumes it; the old connection is closed.
  RawPeer again(port());
  again.send_hello(1, "robot1-token", "sam", one.session_secret(), SAM);
  const Welcome resumed = welcome_of(again);
  EXPECT_EQ(resumed.session_secret(), one.session_secret());
  auto goodbye = first.read_non_ping();
  ASSERT_TRUE(goodbye && goodbye->has_goodbye());
  EXPECT_EQ(goodbye->goodbye().status(), UNAVAILABLE);
  EXPECT_EQ(goodbye->goodbye().reason(), "session resumed from another connection");

  wait_opened(4);
  const auto ids = handler.identities();
  EXPECT_EQ(ids[3].session, ids[0].session);
  EXPECT_NE(ids[1].session, ids[0].session);
  EXPECT_NE(ids[2].session, ids[0].session);
  EXPECT_EQ(ids[1].name, "alice");
}

TEST_F(PlanetIdentity, AHelloAskingMoreThanTheCredentialGrantsIsRefused) {
  RawPeer raw(port());
  raw.send_hello(1, "viewer-token", "sam@robot9", "", SAM);
  EXPECT_TRUE(closed_with(raw, Frame::kRefused, PERMISSION_DENIED,
                          "credential 'viewer' has role client; Hello asks for sam (to register services)"));
  EXPECT_TRUE(handler.opened().empty());
}

TEST(PlanetOpenServer, PeerNamesAreValidated) {
  TestHandler handler;
  StartedServer server(handler);
  for (const std::string& name : {std::string(), std::string(129, 'a'), std::string("bad name"),
                                  std::string("camus-server"), std::string("x\ny")}) {
    RawPeer raw(server.port());
    raw.send_hello(1, "", name);
    auto refused = raw.read_frame();
    ASSERT_TRUE(refused && refused->has_refused()) << name;
    EXPECT_EQ(refused->refused().status(), BAD_ARGUMENTS);
    EXPECT_EQ(refused->refused().reason().rfind("peer_name is not valid: ", 0), 0u) << refused->refused().reason();
  }
  RawPeer fine(server.port());
  fine.send_hello(1, "", "sam@robot1:a/b_c-d.e");
  const Welcome welcome = welcome_of(fine);
  EXPECT_EQ(welcome.identity(), "anonymous");  // an open server
  EXPECT_EQ(welcome.role(), OPERATOR);
}

// The C++ client resumes its session after a connection drop; neither side logs the secret.
TEST_F(PlanetIdentity, ClientResumesItsSessionAndTheSecretIsNeverLogged) {
  std::ostringstream log;
  auto sink = std::make_shared<spdlog::sinks::ostream_sink_mt>(log);
  auto previous = spdlog::default_logger();
  auto capture = std::make_shared<spdlog::logger>("capture", sink);
  capture->set_level(spdlog::level::trace);
  spdlog::set_default_logger(capture);

  ClientOptions copts = client_options(port(), "sam");
  copts.token = "robot1-token";
  copts.role = SAM;
  std::string secret;
  {
    Client client(copts);
    client.start();
    ASSERT_TRUE(client.wait_connected(5s)) << client.last_error();
    ASSERT_TRUE(eventually([&] { return handler.session_of("sam") != nullptr; }));
    // Learn the secret the way a stranger cannot: from the server's side of the handshake.
    RawPeer probe(port());
    probe.send_hello(1, "robot1-token", "probe");
    secret = welcome_of(probe).session_secret();  // a secret of another session, same format
    wait_opened(2);
    handler.session_of("sam")->close(UNAVAILABLE, "test drops the connection");
    ASSERT_TRUE(eventually([&] {
      const auto ids = handler.identities();
      return ids.size() == 3 && client.connected();
    }));
    const auto ids = handler.identities();
    EXPECT_EQ(ids[2].session, ids[0].session) << "the reconnect resumed the first session";
    EXPECT_EQ(client.welcome().identity(), "robot1");
    client.stop();
  }
  server_->stop();
  spdlog::set_default_logger(previous);
  const std::string text = log.str();
  EXPECT_NE(text.find("resumed"), std::string::npos) << text;
  // No 64-hex string (the secrets' form) anywhere in what both sides logged at trace level.
  EXPECT_FALSE(std::regex_search(text, std::regex("[0-9a-f]{64}"))) << text;
  EXPECT_EQ(text.find(secret), std::string::npos);
}

TEST_F(PlanetIdentity, ReplacedCredentialsCloseOnlyTheSessionsTheyNoLongerAdmit) {
  RawPeer alice(port());
  alice.send_hello(1, "alice-token", "alice");
  const Welcome alice_welcome = welcome_of(alice);
  RawPeer robot(port());
  robot.send_hello(1, "robot1-token", "robot", "", SAM);
  welcome_of(robot);
  RawPeer viewer(port());
  viewer.send_hello(1, "viewer-token", "viewer");
  welcome_of(viewer);
  ASSERT_TRUE(eventually([&] { return handler.identities().size() == 3; }));

  // alice removed, robot1's role lowered, viewer unchanged, bob added.
  EXPECT_EQ(
      server_->set_authenticator(credentials(
          {{"robot1", CLIENT, "robot1-token"}, {"viewer", CLIENT, "viewer-token"}, {"bob", OPERATOR, "bob-token"}})),
      2u);
  for (RawPeer* closed : {&alice, &robot}) {
    auto goodbye = closed->read_non_ping();
    ASSERT_TRUE(goodbye && goodbye->has_goodbye());
    EXPECT_EQ(goodbye->goodbye().status(), UNAUTHENTICATED);
  }
  ASSERT_TRUE(eventually([&] { return handler.close_reason_of("alice").has_value(); }));
  EXPECT_FALSE(handler.close_reason_of("viewer").has_value());
  RawPeer bob(port());
  bob.send_hello(1, "bob-token", "bob");
  EXPECT_EQ(welcome_of(bob).identity(), "bob");
  RawPeer alice_again(port());
  alice_again.send_hello(1, "alice-token", "alice", alice_welcome.session_secret());
  auto refused = alice_again.read_frame();
  ASSERT_TRUE(refused && refused->has_refused());
  EXPECT_EQ(refused->refused().reason(), "wrong token");
}

}  // namespace
}  // namespace urs::planet::testing
