// Planet client against a real Server: calls, deadlines, chunking, reconnection and what it
// restores, publishes, subscriptions, the provider role, and a dead server.

#include "urs/planet/client.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <atomic>
#include <condition_variable>
#include <future>
#include <mutex>
#include <thread>

#include "support.hpp"
#include "urs/planet/server.hpp"

namespace urs::planet::testing {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;

// Collects replies in arrival order.
class Replies {
 public:
  ReplyHandler handler(const std::string& tag) {
    return [this, tag](CallResult result) {
      std::lock_guard<std::mutex> lock(mutex_);
      got_.emplace_back(tag, std::move(result));
      changed_.notify_all();
    };
  }
  bool wait_count(size_t count, std::chrono::milliseconds timeout = 10s) {
    std::unique_lock<std::mutex> lock(mutex_);
    return changed_.wait_for(lock, timeout, [&] { return got_.size() >= count; });
  }
  std::vector<std::pair<std::string, CallResult>> got() {
    std::lock_guard<std::mutex> lock(mutex_);
    return got_;
  }

 private:
  std::mutex mutex_;
  std::condition_variable changed_;
  std::vector<std::pair<std::string, CallResult>> got_;
};

TEST(PlanetClient, LargePayloadDoesNotHoldBackASmallCall) {
  TestHandler handler;
  StartedServer server(handler);
  Client client(client_options(server.port(), "camera"));
  ASSERT_TRUE(start_and_connect(client));

  std::string image(921600, '\0');
  for (size_t i = 0; i < image.size(); ++i) image[i] = static_cast<char>(i % 251);
  Replies replies;
  // Issued from a callback, i.e. on the client's I/O thread, so that the image is certainly still
  // queued when the small call is made (from the test thread, a slow scheduler could let the
  // whole image go out in between). The Outbox unit tests cover "after at most one chunk".
  client.call_async("echo", "warm-up", "", 10s, [&](CallResult) {
    client.call_async("echo", "upload", image, 10s, replies.handler("large"));
    client.call_async("echo", "status", "small", 10s, replies.handler("small"));
  });
  ASSERT_TRUE(replies.wait_count(2));
  const auto got = replies.got();
  EXPECT_EQ(got[0].first, "small") << "the small call's reply must not wait for the image";
  EXPECT_EQ(got[1].first, "large");
  EXPECT_TRUE(got[0].second.ok());
  ASSERT_TRUE(got[1].second.ok()) << got[1].second.message;
  EXPECT_EQ(got[1].second.payload, image);

  // The server, too, saw the small request complete first: the client interleaved it.
  std::vector<std::string> operations;
  for (const auto& r : handler.received_from("camera")) {
    if (r.frame.has_request()) operations.push_back(r.frame.request().operation());
  }
  EXPECT_THAT(operations, ElementsAre("warm-up", "status", "upload"));
}

TEST(PlanetClient, RequestOverTheServersLimitFailsLocally) {
  TestHandler handler;
  ServerOptions options = server_options();
  options.max_message_bytes = 1u << 20;
  StartedServer server(handler, options);
  Client client(client_options(server.port(), "big"));
  ASSERT_TRUE(start_and_connect(client));
  const CallResult result = client.call("echo", "upload", std::string(2u << 20, 'x'));
  EXPECT_EQ(result.status, PAYLOAD_TOO_LARGE);
  EXPECT_THAT(result.message, HasSubstr("exceeds the server's max_message_bytes 1048576"));
  EXPECT_TRUE(client.call("echo", "x", "fine").ok());
}

TEST(PlanetClient, DeadlineExceededAndALateReplyIsIgnored) {
  TestHandler handler;
  StartedServer server(handler);
  Client client(client_options(server.port(), "impatient"));
  ASSERT_TRUE(start_and_connect(client));

  const auto start = Clock::now();
  const CallResult result = client.call("silent", "wait", "", 200ms);
  const long took = elapsed_ms(start);
  EXPECT_EQ(result.status, DEADLINE_EXCEEDED);
  EXPECT_EQ(result.message, "no reply from silent.wait within 200 ms");
  EXPECT_GE(took, 190);  // not before the deadline; the message above says it was the deadline that ended it

  // The request carried its deadline.
  const auto received = handler.received_from("impatient");
  ASSERT_FALSE(received.empty());
  EXPECT_GT(received.back().frame.request().deadline_ms(), 0u);
  EXPECT_LE(received.back().frame.request().deadline_ms(), 200u);

  // The reply arrives after all: it is dropped, and the client carries on.
  const auto silent = handler.silent();
  ASSERT_EQ(silent.size(), 1u);
  Frame late;
  late.mutable_reply()->set_call_id(silent[0].call_id);
  late.mutable_reply()->set_payload("too late");
  ASSERT_TRUE(silent[0].session.lock()->send(late));
  const CallResult after = client.call("echo", "x", "after");
  EXPECT_TRUE(after.ok());
  EXPECT_EQ(after.payload, "after");
}

TEST(PlanetClient, ACallWithoutDeadlineLeavesItToTheServer) {
  TestHandler handler;
  StartedServer server(handler);
  ClientOptions options = client_options(server.port(), "patient");
  options.queue_timeout = 300ms;  // bounds only the wait for a connection
  Client client(options);
  ASSERT_TRUE(start_and_connect(client));

  // Sent with deadline_ms 0 (the service's deadline applies at the server) and answered long
  // after queue_timeout: the client waited for the answer.
  Replies replies;
  client.call_async("silent", "wait", "", 0ms, replies.handler("no deadline"));
  ASSERT_TRUE(eventually([&] { return handler.silent().size() == 1; }));
  const auto received = handler.received_from("patient");
  ASSERT_FALSE(received.empty());
  EXPECT_EQ(received.back().frame.request().deadline_ms(), 0u);
  EXPECT_FALSE(replies.wait_count(1, 900ms)) << "the client gave up on its own";
  Frame answer;
  answer.mutable_reply()->set_call_id(handler.silent()[0].call_id);
  answer.mutable_reply()->set_payload("late but wanted");
  ASSERT_TRUE(handler.silent()[0].session.lock()->send(answer));
  ASSERT_TRUE(replies.wait_count(1));
  EXPECT_TRUE(replies.got()[0].second.ok()) << replies.got()[0].second.message;
  EXPECT_EQ(replies.got()[0].second.payload, "late but wanted");
}

TEST(PlanetClient, ACallWithoutDeadlineWaitsForAConnectionOnlyUpToTheQueueTimeout) {
  uint16_t port = 0;
  {
    RawListener listener;  // a port that was free a moment ago: no server will answer
    port = listener.port();
  }
  ClientOptions options = client_options(port, "unsent");
  options.queue_timeout = 200ms;
  Client client(options);
  client.start();
  const CallResult result = client.call("echo", "x", "y");
  EXPECT_EQ(result.status, UNAVAILABLE);
  EXPECT_EQ(result.message, "echo.x not sent: no connection to 127.0.0.1:" + std::to_string(port) + " within 200 ms");
}

TEST(PlanetClient, ReconnectRestoresRegistrationsSubscriptionsAndQueuedCalls) {
  TestHandler handler;
  handler.replay_overlap = true;  // the server replays one event the client already has
  auto server = std::make_unique<Server>(server_options(), handler);
  server->start();
  const uint16_t port = server->port();

  ClientOptions options = client_options(port, "sam");
  options.role = SAM;
  options.max_queued = 3;
  Client sam(options);
  Replies registered;
  camus::RegisterRequest registration;
  registration.mutable_service()->set_name("robot1.navigation");
  registration.mutable_service()->set_interface("urs.urc.Navigation");
  sam.register_service(registration, registered.handler("register"));
  std::mutex events_mutex;
  std::vector<uint64_t> seqs;
  sam.subscribe("kr/#", [&](const Event& event) {
    std::lock_guard<std::mutex> lock(events_mutex);
    seqs.push_back(event.seq());
  });
  auto seen = [&] {
    std::lock_guard<std::mutex> lock(events_mutex);
    return seqs;
  };
  std::atomic<int> connects{0};
  std::mutex reasons_mutex;
  std::vector<std::string> disconnects;
  sam.on_connected([&](const Welcome&) { ++connects; });
  sam.on_disconnected([&](const std::string& reason) {
    std::lock_guard<std::mutex> lock(reasons_mutex);
    disconnects.push_back(reason);
  });
  ASSERT_TRUE(start_and_connect(sam));
  ASSERT_TRUE(registered.wait_count(1));
  EXPECT_TRUE(registered.got()[0].second.ok());
  ASSERT_TRUE(eventually([&] { return handler.subscriptions() == 1; }));

  Client publisher(client_options(port, "pub"));
  ASSERT_TRUE(start_and_connect(publisher));
  ASSERT_TRUE(publisher.publish("kr/robot1/arrived", "first", "text/plain").ok());
  ASSERT_TRUE(eventually([&] { return seen() == std::vector<uint64_t>{1}; }));
  const std::string first_instance = sam.welcome().server_instance();

  // A call on the wire when the connection drops fails and is not retried.
  Replies in_flight;
  sam.call_async("silent", "wait", "", 10s, in_flight.handler("in-flight"));
  ASSERT_TRUE(eventually([&] { return handler.silent().size() == 1; }));

  server.reset();  // the server process goes away
  ASSERT_TRUE(in_flight.wait_count(1));
  EXPECT_EQ(in_flight.got()[0].second.status, UNAVAILABLE);
  EXPECT_EQ(in_flight.got()[0].second.message, "connection to server lost");
  ASSERT_TRUE(eventually([&] { return !sam.connected(); }));

  // While disconnected: calls queue up to max_queued; then UNAVAILABLE with the reason.
  Replies queued;
  for (int i = 1; i <= 3; ++i) {
    sam.call_async("echo", "say", "q" + std::to_string(i), 10s, queued.handler("q" + std::to_string(i)));
  }
  sam.call_async("echo", "say", "q4", 10s, queued.handler("q4"));
  ASSERT_TRUE(queued.wait_count(1));
  const std::string full = "not connected to 127.0.0.1:" + std::to_string(port) + " and the queue of 3 is full";
  EXPECT_EQ(queued.got()[0].first, "q4");
  EXPECT_EQ(queued.got()[0].second.status, UNAVAILABLE);
  EXPECT_EQ(queued.got()[0].second.message, full);
  const CallResult publish_full = sam.publish("kr/x", "y", "");
  EXPECT_EQ(publish_full.status, UNAVAILABLE);
  EXPECT_EQ(publish_full.message, full);

  // The server comes back on the same port.
  server = std::make_unique<Server>(server_options(port), handler);
  server->start();
  ASSERT_TRUE(queued.wait_count(4));
  const auto replies = queued.got();
  for (int i = 1; i <= 3; ++i) {
    EXPECT_EQ(replies[i].first, "q" + std::to_string(i));
    EXPECT_TRUE(replies[i].second.ok()) << replies[i].second.message;
    EXPECT_EQ(replies[i].second.payload, "q" + std::to_string(i));
  }
  ASSERT_TRUE(sam.wait_connected(5s));
  EXPECT_NE(sam.welcome().server_instance(), first_instance);
  EXPECT_EQ(connects.load(), 2);
  {
    std::lock_guard<std::mutex> lock(reasons_mutex);
    ASSERT_EQ(disconnects.size(), 1u);
    EXPECT_EQ(disconnects[0], "goodbye: server shutting down");
  }

  // The restarted server does not know the first session's secret, so the client got a new
  // session; on it: registration, then the subscription resuming after the last event seen, then
  // the queued calls in order.
  EXPECT_EQ(handler.registrations_of("robot1.navigation"), 2);
  EXPECT_TRUE(handler.provider_registered("robot1.navigation"));
  auto frames = handler.received_from("sam");
  const uint64_t second_session = frames.back().session;
  frames.erase(std::remove_if(frames.begin(), frames.end(), [&](const auto& r) { return r.session != second_session; }),
               frames.end());
  ASSERT_GE(frames.size(), 5u);
  EXPECT_EQ(frames[0].frame.request().service(), "camus.registry");
  EXPECT_EQ(frames[0].frame.request().operation(), "Register");
  ASSERT_TRUE(frames[1].frame.has_subscribe());
  EXPECT_EQ(frames[1].frame.subscribe().pattern(), "kr/#");
  EXPECT_EQ(frames[1].frame.subscribe().resume_after_seq(), 1u);
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(frames[2 + i].frame.request().payload(), "q" + std::to_string(i + 1));
  }

  // Events flow again; the replayed duplicate (seq 1) was dropped.
  ASSERT_TRUE(publisher.wait_connected(5s));
  ASSERT_TRUE(publisher.publish("kr/robot1/arrived", "second", "text/plain").ok());
  ASSERT_TRUE(eventually([&] { return seen().size() >= 2; }));
  EXPECT_EQ(seen(), (std::vector<uint64_t>{1, 2}));
}

TEST(PlanetClient, PublishesAreResentUntilAcknowledgedAndDeduped) {
  TestHandler handler;
  handler.ack_publishes = false;
  auto server = std::make_unique<Server>(server_options(), handler);
  server->start();
  const uint16_t port = server->port();
  ClientOptions options = client_options(port, "publisher");
  options.max_queued = 2;
  Client client(options);
  ASSERT_TRUE(start_and_connect(client));
  ASSERT_TRUE(client.publish("kr/a", "1", "").ok());
  ASSERT_TRUE(client.publish("kr/a", "2", "").ok());
  // Both are unacknowledged: they fill the queue.
  const CallResult full = client.publish("kr/a", "3", "");
  EXPECT_EQ(full.status, UNAVAILABLE);
  EXPECT_THAT(full.message, HasSubstr("publishes awaiting acknowledgement"));
  ASSERT_TRUE(eventually([&] { return handler.stored_events() == 2; }));

  server.reset();
  handler.ack_publishes = true;
  ASSERT_TRUE(eventually([&] { return !client.connected(); }));
  server = std::make_unique<Server>(server_options(port), handler);
  server->start();
  ASSERT_TRUE(client.wait_connected(5s));
  // Resent in publish_id order; the server recognised both as duplicates.
  ASSERT_TRUE(eventually([&] { return handler.duplicate_publishes() == 2; }));
  EXPECT_EQ(handler.stored_events(), 2u);
  std::vector<uint64_t> ids;
  for (const auto& r : handler.received_from("publisher")) {
    if (r.frame.has_publish()) ids.push_back(r.frame.publish().publish_id());
  }
  EXPECT_THAT(ids, ElementsAre(1, 2, 1, 2));
  // Acknowledged now, so the queue has room again.
  EXPECT_TRUE(eventually([&] { return client.publish("kr/a", "3", "").ok(); }));
}

TEST(PlanetClient, ProviderAnswersRoutedRequests) {
  TestHandler handler;
  StartedServer server(handler);

  ClientOptions provider_options = client_options(server.port(), "tts");
  provider_options.role = SAM;
  Client provider(provider_options);
  std::mutex workers_mutex;
  std::vector<std::thread> workers;
  std::atomic<int> oneways{0};
  provider.set_request_handler([&](const Request& request, Responder responder) {
    if (request.oneway()) {
      EXPECT_FALSE(responder.pending());
      ++oneways;
    } else if (request.operation() == "speak") {
      // Answer later, from another thread.
      std::lock_guard<std::mutex> lock(workers_mutex);
      workers.emplace_back([responder = std::move(responder), text = request.payload()]() mutable {
        responder.reply(CallResult::success("spoken:" + text));
      });
    } else if (request.operation() == "busy") {
      responder.reply(CallResult::user_exception("urs.urc.TextToSpeech.Busy", "exc", "busy"));
    }
    // Anything else: the responder is dropped unanswered.
  });
  Replies registered;
  camus::RegisterRequest registration;
  registration.mutable_service()->set_name("robot1.tts");
  provider.register_service(registration, registered.handler("register"));
  provider.start();
  ASSERT_TRUE(registered.wait_count(1));
  ASSERT_TRUE(registered.got()[0].second.ok());

  Client caller(client_options(server.port(), "caller"));
  ASSERT_TRUE(start_and_connect(caller));
  const CallResult spoken = caller.call("robot1.tts", "speak", "hello");
  EXPECT_TRUE(spoken.ok()) << spoken.message;
  EXPECT_EQ(spoken.payload, "spoken:hello");
  const CallResult busy = caller.call("robot1.tts", "busy", "");
  EXPECT_EQ(busy.status, USER_EXCEPTION);
  EXPECT_EQ(busy.exception_type, "urs.urc.TextToSpeech.Busy");
  EXPECT_EQ(busy.payload, "exc");
  EXPECT_EQ(busy.message, "busy");
  const CallResult dropped = caller.call("robot1.tts", "mumble", "");
  EXPECT_EQ(dropped.status, INTERNAL);
  EXPECT_EQ(dropped.message, "provider dropped the request");
  EXPECT_TRUE(caller.oneway("robot1.tts", "notify", "x"));
  EXPECT_TRUE(eventually([&] { return oneways.load() == 1; }));

  Replies unregistered;
  provider.unregister_service("robot1.tts", unregistered.handler("unregister"));
  ASSERT_TRUE(unregistered.wait_count(1));
  EXPECT_TRUE(unregistered.got()[0].second.ok());
  EXPECT_FALSE(handler.provider_registered("robot1.tts"));
  std::lock_guard<std::mutex> lock(workers_mutex);
  for (auto& worker : workers) worker.join();
}

TEST(PlanetClient, DetectsASilentServerByHeartbeatAndReconnects) {
  // A fake server: answers Hello with a Welcome (heartbeat timeout 300 ms), then says nothing.
  RawListener listener;
  std::atomic<bool> done{false};
  std::atomic<int> accepted{0};
  std::thread fake([&] {
    std::vector<std::unique_ptr<RawPeer>> peers;
    while (!done) {
      auto peer = listener.accept(50ms);
      if (!peer) continue;
      ++accepted;
      if (!peer->read_frame()) continue;
      Frame welcome;
      welcome.mutable_welcome()->set_version(1);
      welcome.mutable_welcome()->set_space("fake");
      welcome.mutable_welcome()->set_heartbeat_interval_ms(100);
      welcome.mutable_welcome()->set_heartbeat_timeout_ms(300);
      welcome.mutable_welcome()->set_max_message_bytes(1u << 20);
      welcome.mutable_welcome()->set_chunk_bytes(64u << 10);
      peer->send_frame(welcome);
      peers.push_back(std::move(peer));
    }
  });

  Client client(client_options(listener.port(), "watchful"));
  std::mutex mutex;
  std::vector<std::string> reasons;
  Clock::time_point connected_at;
  long silent_for = -1;
  client.on_connected([&](const Welcome&) {
    std::lock_guard<std::mutex> lock(mutex);
    connected_at = Clock::now();
  });
  client.on_disconnected([&](const std::string& reason) {
    std::lock_guard<std::mutex> lock(mutex);
    if (reasons.empty()) silent_for = elapsed_ms(connected_at);
    reasons.push_back(reason);
  });
  client.start();
  EXPECT_TRUE(eventually([&] {
    std::lock_guard<std::mutex> lock(mutex);
    return !reasons.empty();
  }));
  EXPECT_TRUE(eventually([&] { return accepted.load() >= 2; })) << "the client reconnects";
  client.stop();
  done = true;
  fake.join();
  std::lock_guard<std::mutex> lock(mutex);
  ASSERT_FALSE(reasons.empty());
  EXPECT_EQ(reasons[0], "heartbeat timeout after 300 ms");
  EXPECT_GE(silent_for, 250);
  EXPECT_LE(silent_for, 2000);
}

TEST(PlanetClient, ConnectFailureIsReported) {
  uint16_t port = 0;
  {
    RawListener listener;  // a port that was free a moment ago
    port = listener.port();
  }
  Client client(client_options(port, "lonely"));
  client.start();
  EXPECT_TRUE(eventually([&] { return !client.last_error().empty(); }));
  EXPECT_THAT(client.last_error(), HasSubstr("cannot connect to 127.0.0.1:" + std::to_string(port)));
  EXPECT_FALSE(client.wait_connected(50ms));
}

TEST(PlanetClient, StopFailsPendingCallsAndCallbacksCannotBlock) {
  TestHandler handler;
  StartedServer server(handler);
  Client client(client_options(server.port(), "stopper"));
  std::optional<CallResult> from_callback;
  client.on_connected([&](const Welcome&) { from_callback = client.call("echo", "x", "y"); });
  ASSERT_TRUE(start_and_connect(client));
  Replies pending;
  client.call_async("silent", "wait", "", 10s, pending.handler("pending"));
  ASSERT_TRUE(eventually([&] { return handler.silent().size() == 1; }));
  client.stop();
  ASSERT_TRUE(pending.wait_count(1, 1s));
  EXPECT_EQ(pending.got()[0].second.status, UNAVAILABLE);
  EXPECT_EQ(pending.got()[0].second.message, "client stopped");
  ASSERT_TRUE(from_callback);
  EXPECT_EQ(from_callback->status, INTERNAL);
  EXPECT_THAT(from_callback->message, HasSubstr("use call_async()"));
  const CallResult after = client.call("echo", "x", "y");
  EXPECT_EQ(after.status, UNAVAILABLE);
  EXPECT_EQ(after.message, "client stopped");
  EXPECT_TRUE(eventually([&] { return handler.close_reason_of("stopper").has_value(); }));
  EXPECT_EQ(*handler.close_reason_of("stopper"), "goodbye from peer (OK): client stopped");
}

// unsubscribe() returns only once the subscription's handler is no longer running, so what the
// handler uses may be destroyed right after (`urs watch` and the bridge's shared state rely on
// it); from the handler itself it returns at once.
TEST(PlanetClient, UnsubscribeWaitsForTheHandlerRunningNow) {
  TestHandler handler;
  StartedServer server(handler);
  Client client(client_options(server.port(), "watcher"));
  std::mutex mutex;
  std::condition_variable changed;
  bool entered = false;
  bool release = false;
  int runs = 0;
  uint64_t inner = 0;
  const uint64_t id = client.subscribe("watch/#", [&](const Event&) {
    std::unique_lock<std::mutex> lock(mutex);
    ++runs;
    entered = true;
    changed.notify_all();
    changed.wait(lock, [&] { return release; });
  });
  inner = client.subscribe("self/#", [&](const Event&) { client.unsubscribe(inner); });  // must not deadlock
  ASSERT_TRUE(start_and_connect(client));
  ASSERT_TRUE(eventually([&] { return handler.subscriptions() == 2; }));
  Client publisher(client_options(server.port(), "pub"));
  ASSERT_TRUE(start_and_connect(publisher));
  ASSERT_TRUE(publisher.publish("watch/a", "1", "text/plain").ok());
  {
    std::unique_lock<std::mutex> lock(mutex);
    ASSERT_TRUE(changed.wait_for(lock, 10s, [&] { return entered; }));
  }
  auto unsubscribed = std::async(std::launch::async, [&] { client.unsubscribe(id); });
  EXPECT_EQ(unsubscribed.wait_for(200ms), std::future_status::timeout)
      << "unsubscribe() returned while the handler was still running";
  {
    std::lock_guard<std::mutex> lock(mutex);
    release = true;
  }
  changed.notify_all();
  ASSERT_EQ(unsubscribed.wait_for(10s), std::future_status::ready);
  ASSERT_TRUE(publisher.publish("watch/b", "2", "text/plain").ok());
  ASSERT_TRUE(publisher.publish("self/x", "3", "text/plain").ok());
  ASSERT_TRUE(eventually([&] { return handler.subscriptions() == 0; })) << "both ended at the server";
  std::lock_guard<std::mutex> lock(mutex);
  EXPECT_EQ(runs, 1);
}

}  // namespace
}  // namespace urs::planet::testing
