// Planet server transport against raw TCP peers and real clients: handshake, authentication,
// versioning, heartbeats, and isolation of misbehaving connections.

#include "urs/planet/server.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <atomic>
#include <thread>

#include "support.hpp"
#include "urs/planet/client.hpp"

namespace urs::planet::testing {
namespace {

using ::testing::AllOf;
using ::testing::HasSubstr;

TEST(PlanetServer, HandshakeSucceedsAndWelcomeCarriesTheSettings) {
  TestHandler handler;
  ServerOptions options = server_options();
  options.authenticator = one_token("s3cret", SAM, "robot1");
  options.heartbeat_interval = 500ms;
  options.heartbeat_timeout = 2000ms;
  options.max_message_bytes = 8u << 20;
  options.chunk_bytes = 32u << 10;
  StartedServer server(handler, options);
  ASSERT_NE(server.port(), 0);

  ClientOptions copts = client_options(server.port(), "sam@robot1");
  copts.token = "s3cret";
  copts.role = SAM;
  Client client(copts);
  client.start();
  ASSERT_TRUE(client.wait_connected(5s)) << client.last_error();

  const Welcome welcome = client.welcome();
  EXPECT_EQ(welcome.version(), 1u);
  EXPECT_EQ(welcome.space(), "kr");
  EXPECT_EQ(welcome.server_instance().size(), 16u);
  EXPECT_EQ(welcome.heartbeat_interval_ms(), 500u);
  EXPECT_EQ(welcome.heartbeat_timeout_ms(), 2000u);
  EXPECT_EQ(welcome.max_message_bytes(), 8u << 20);
  EXPECT_EQ(welcome.chunk_bytes(), 32u << 10);
  EXPECT_EQ(welcome.identity(), "robot1");
  EXPECT_EQ(welcome.role(), SAM);
  EXPECT_TRUE(welcome.session_secret().empty()) << "the client keeps the secret to itself";

  ASSERT_TRUE(eventually([&] { return handler.opened().size() == 1; }));
  const Hello hello = handler.opened()[0];
  EXPECT_EQ(hello.peer_name(), "sam@robot1");
  EXPECT_EQ(hello.role(), SAM);
  EXPECT_EQ(hello.version(), 1u);
  EXPECT_TRUE(hello.token().empty()) << "the token must not reach the handler";
  EXPECT_TRUE(hello.session_secret().empty()) << "nor the session secret";
  EXPECT_EQ(handler.identities()[0].name, "robot1");
  EXPECT_EQ(handler.identities()[0].role, SAM);

  const CallResult result = client.call("echo", "say", "hello");
  EXPECT_TRUE(result.ok()) << result.message;
  EXPECT_EQ(result.payload, "hello");
  EXPECT_EQ(client.last_error(), "");
}

TEST(PlanetServer, MissingTokenIsRefusedWithTheReason) {
  TestHandler handler;
  ServerOptions options = server_options();
  options.authenticator = one_token("s3cret");
  StartedServer server(handler, options);

  Client client(client_options(server.port(), "no-token"));
  client.start();
  EXPECT_TRUE(eventually([&] { return !client.last_error().empty(); }));
  EXPECT_EQ(client.last_error(), "refused: token required: pass --token-file");
  EXPECT_FALSE(client.connected());
  EXPECT_TRUE(handler.opened().empty());

  RawPeer raw(server.port());
  raw.send_hello(1, "");
  EXPECT_TRUE(closed_with(raw, Frame::kRefused, UNAUTHENTICATED, "token required: pass --token-file"));
}

TEST(PlanetServer, WrongTokenIsRefusedAndTheClientKeepsRetrying) {
  TestHandler handler;
  ServerOptions options = server_options();
  options.authenticator = one_token("s3cret");
  StartedServer server(handler, options);

  ClientOptions copts = client_options(server.port(), "wrong-token");
  copts.token = "s3cres";
  Client client(copts);
  client.start();
  EXPECT_TRUE(eventually([&] { return client.last_error() == "refused: wrong token"; })) << client.last_error();

  RawPeer raw(server.port());
  raw.send_hello(1, "s3cret-and-more");
  EXPECT_TRUE(closed_with(raw, Frame::kRefused, UNAUTHENTICATED, "wrong token"));
  EXPECT_TRUE(handler.opened().empty());
  EXPECT_FALSE(client.connected());
}

TEST(PlanetServer, VersionMismatchIsRefused) {
  TestHandler handler;
  StartedServer server(handler);
  RawPeer raw(server.port());
  raw.send_hello(2);
  EXPECT_TRUE(closed_with(raw, Frame::kRefused, INTERNAL, "protocol version 2 not supported, server speaks 1"));
  EXPECT_TRUE(handler.opened().empty());
}

TEST(PlanetServer, FirstFrameMustBeHello) {
  TestHandler handler;
  StartedServer server(handler);
  RawPeer raw(server.port());
  Frame request;
  request.mutable_request()->set_service("echo");
  raw.send_frame(request);
  EXPECT_TRUE(closed_with(raw, Frame::kGoodbye, BAD_ARGUMENTS, "expected Hello as the first frame, got request"));
}

TEST(PlanetServer, HelloMustArriveWithinTheHandshakeTimeout) {
  TestHandler handler;
  ServerOptions options = server_options();
  options.handshake_timeout = 200ms;
  StartedServer server(handler, options);
  const auto start = Clock::now();
  RawPeer raw(server.port());
  EXPECT_TRUE(closed_with(raw, Frame::kGoodbye, DEADLINE_EXCEEDED, "no Hello within 200 ms"));
  EXPECT_GE(elapsed_ms(start), 150);
}

TEST(PlanetServer, HeartbeatClosesASilentPeer) {
  TestHandler handler;
  StartedServer server(handler, heartbeat_options(100ms, 400ms));

  RawPeer raw(server.port());
  raw.send_hello(1, "", "silent");
  auto welcome = raw.read_frame();
  ASSERT_TRUE(welcome && welcome->has_welcome());
  const auto since = Clock::now();
  // From here on the raw peer sends nothing (and does not answer Pings).
  ASSERT_TRUE(eventually([&] { return handler.close_reason_of("silent").has_value(); }, 5s));
  const long took = elapsed_ms(since);
  EXPECT_EQ(*handler.close_reason_of("silent"), "heartbeat timeout after 400 ms");
  EXPECT_GE(took, 350);  // not before the timeout; the reason above says it was the heartbeat's

  int pings = 0;
  std::optional<Frame> last;
  while (auto frame = raw.read_frame(2s)) {
    if (frame->has_ping()) ++pings;
    last = frame;
  }
  EXPECT_GE(pings, 2) << "the server pings every heartbeat_interval";
  ASSERT_TRUE(last && last->has_goodbye());
  EXPECT_EQ(last->goodbye().status(), UNAVAILABLE);
  EXPECT_EQ(last->goodbye().reason(), "heartbeat timeout after 400 ms");
}

TEST(PlanetServer, APeerThatAnswersPingsStaysOpen) {
  TestHandler handler;
  StartedServer server(handler, heartbeat_options(100ms, 600ms));
  Client client(client_options(server.port(), "idle"));
  ASSERT_TRUE(start_and_connect(client));
  // Idle for several heartbeat timeouts: only Ping/Pong flows. Nothing must close.
  EXPECT_FALSE(eventually([&] { return !handler.closes().empty(); }, 1800ms));
  EXPECT_TRUE(client.connected());
  EXPECT_TRUE(client.call("echo", "x", "still here").ok());
}

TEST(PlanetServer, GarbageAndOversizedFramesCloseOnlyTheirConnection) {
  TestHandler handler;
  StartedServer server(handler);

  Client good(client_options(server.port(), "good"));
  ASSERT_TRUE(start_and_connect(good));
  std::atomic<bool> stop{false};
  std::atomic<int> ok_calls{0};
  std::atomic<int> failed_calls{0};
  std::thread caller([&] {
    while (!stop) {
      const CallResult result = good.call("echo", "ping", "p", 2000ms);
      (result.ok() && result.payload == "p" ? ok_calls : failed_calls)++;
    }
  });

  auto open_raw = [&](const std::string& name) {
    auto raw = std::make_unique<RawPeer>(server.port());
    raw->send_hello(1, "", name);
    auto welcome = raw->read_frame();
    EXPECT_TRUE(welcome && welcome->has_welcome()) << name;
    return raw;
  };

  // Garbage: a well-framed body that is not a Frame.
  auto garbage = open_raw("garbage");
  std::string bytes;
  append_length_prefix(bytes, 6);
  bytes += std::string("\xff\xff\xff\xff\xff\xff", 6);
  garbage->send_bytes(bytes);
  auto goodbye = garbage->read_non_ping();
  ASSERT_TRUE(goodbye && goodbye->has_goodbye());
  EXPECT_EQ(goodbye->goodbye().status(), BAD_ARGUMENTS);
  EXPECT_THAT(goodbye->goodbye().reason(), HasSubstr("does not parse as a urs.planet.Frame"));
  EXPECT_TRUE(garbage->closed_by_server());

  // Oversized: a length prefix far over chunk_bytes.
  auto oversized = open_raw("oversized");
  bytes.clear();
  append_length_prefix(bytes, 0x7fffffff);
  oversized->send_bytes(bytes + "xxxx");
  goodbye = oversized->read_non_ping();
  ASSERT_TRUE(goodbye && goodbye->has_goodbye());
  EXPECT_EQ(goodbye->goodbye().status(), PAYLOAD_TOO_LARGE);
  EXPECT_THAT(goodbye->goodbye().reason(),
              AllOf(HasSubstr("frame of 2147483647 bytes exceeds the limit of 65536 bytes"), HasSubstr("chunk_bytes")));
  EXPECT_TRUE(oversized->closed_by_server());

  // A chunked message announcing more than max_message_bytes.
  auto huge = open_raw("huge");
  Frame chunk;
  chunk.mutable_chunk()->set_message_id(1);
  chunk.mutable_chunk()->set_total_bytes(1ull << 40);
  chunk.mutable_chunk()->set_data("x");
  huge->send_frame(chunk);
  goodbye = huge->read_non_ping();
  ASSERT_TRUE(goodbye && goodbye->has_goodbye());
  EXPECT_EQ(goodbye->goodbye().status(), PAYLOAD_TOO_LARGE);
  EXPECT_THAT(goodbye->goodbye().reason(), HasSubstr("max_message_bytes"));
  EXPECT_TRUE(huge->closed_by_server());

  // Not Planet at all, before any Hello.
  RawPeer http(server.port());
  http.send_bytes("GET / HTTP/1.1\r\nHost: planet\r\n\r\n");
  goodbye = http.read_frame();
  ASSERT_TRUE(goodbye && goodbye->has_goodbye());
  EXPECT_EQ(goodbye->goodbye().status(), PAYLOAD_TOO_LARGE);
  EXPECT_TRUE(http.closed_by_server());

  const int before = ok_calls.load();
  EXPECT_TRUE(eventually([&] { return ok_calls.load() >= before + 20; }));
  stop = true;
  caller.join();
  EXPECT_EQ(failed_calls.load(), 0);
  EXPECT_TRUE(good.connected());
  EXPECT_THAT(handler.close_reason_of("garbage").value_or(""), HasSubstr("protocol error"));
  EXPECT_THAT(handler.close_reason_of("oversized").value_or(""), HasSubstr("protocol error"));
  EXPECT_FALSE(handler.close_reason_of("good").has_value());
}

TEST(PlanetServer, SessionIsClosedWhenItsSendQueueOverflows) {
  TestHandler handler;
  ServerOptions options = server_options();
  options.max_send_queue_bytes = 1u << 20;
  StartedServer server(handler, options);
  RawPeer raw(server.port());  // never reads after the Welcome
  raw.send_hello(1, "", "slow-reader");
  ASSERT_TRUE(eventually([&] { return handler.session_of("slow-reader") != nullptr; }));
  SessionPtr session = handler.session_of("slow-reader");
  Frame event;
  event.mutable_event()->set_topic("kr/camera/image");
  event.mutable_event()->set_payload(std::string(100000, 'i'));
  bool refused = false;
  for (int i = 0; i < 5000 && !refused; ++i) refused = !session->send(event);
  EXPECT_TRUE(refused) << "send() must start failing once the queue is over its limit";
  ASSERT_TRUE(eventually([&] { return handler.close_reason_of("slow-reader").has_value(); }));
  EXPECT_THAT(*handler.close_reason_of("slow-reader"),
              AllOf(HasSubstr("send queue of"), HasSubstr("exceeds max_send_queue_bytes 1048576")));
  EXPECT_FALSE(session->send(event));
}

TEST(PlanetServer, StopClosesEverySessionOnceAndSaysGoodbye) {
  TestHandler handler;
  auto server = std::make_unique<Server>(server_options(), handler);
  server->start();
  RawPeer raw(server->port());
  raw.send_hello(1, "", "raw");
  ASSERT_TRUE(raw.read_frame());
  std::string reason;
  Client client(client_options(server->port(), "client"));
  client.on_disconnected([&](const std::string& why) { reason = why; });
  ASSERT_TRUE(start_and_connect(client));
  ASSERT_TRUE(eventually([&] { return handler.open_sessions() == 2; }));
  server->stop();
  server->stop();  // idempotent
  EXPECT_EQ(handler.open_sessions(), 0u);
  EXPECT_EQ(handler.closes().size(), 2u);
  for (const auto& close : handler.closes()) EXPECT_EQ(close.reason, "server stopped");
  auto goodbye = raw.read_non_ping();
  ASSERT_TRUE(goodbye && goodbye->has_goodbye());
  EXPECT_EQ(goodbye->goodbye().status(), UNAVAILABLE);
  EXPECT_EQ(goodbye->goodbye().reason(), "server shutting down");
  EXPECT_TRUE(eventually([&] { return !client.connected(); }));
  client.stop();
  EXPECT_EQ(reason, "goodbye: server shutting down");
  server.reset();
}

TEST(PlanetServer, ListeningOnABusyPortThrowsNamingTheAddress) {
  TestHandler handler;
  Server first(server_options(), handler);
  ServerOptions options = server_options();
  options.port = first.port();
  try {
    Server second(options, handler);
    FAIL() << "expected std::runtime_error";
  } catch (const std::runtime_error& error) {
    EXPECT_THAT(error.what(), HasSubstr("cannot listen on 127.0.0.1:" + std::to_string(first.port())));
  }
}

TEST(PlanetServer, InvalidOptionsAreReportedTogether) {
  TestHandler handler;
  ServerOptions options = server_options();
  options.chunk_bytes = 10;
  options.heartbeat_timeout = 10ms;
  options.heartbeat_interval = 20ms;
  try {
    Server server(options, handler);
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& error) {
    EXPECT_THAT(error.what(), AllOf(HasSubstr("chunk_bytes 10"), HasSubstr("heartbeat_timeout 10 ms")));
  }
}

}  // namespace
}  // namespace urs::planet::testing
