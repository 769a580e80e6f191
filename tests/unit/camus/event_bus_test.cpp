#include "urs/camus_server/event_bus.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <thread>

#include "fakes.hpp"

namespace urs::camus_server::test {
namespace {

// An event of the server itself (publisher 0), or of session `publisher` with its publish id.
PublishInput event_on(const std::string& topic, const std::string& payload, uint64_t publisher = 0,
                      uint64_t publish_id = 0) {
  PublishInput in;
  in.topic = topic;
  in.payload = payload;
  in.content_type = "text/plain";
  in.source = "tester";
  in.publisher = publisher;
  in.publish_id = publish_id;
  return in;
}

planet::Subscribe subscribe_to(uint64_t id, const std::string& pattern, uint64_t resume_after = 0) {
  planet::Subscribe s;
  s.set_subscription_id(id);
  s.set_pattern(pattern);
  s.set_resume_after_seq(resume_after);
  return s;
}

// The PublishAcks of the publishes given fn() as their callback.
class Acks : public Recorded<planet::PublishAck> {
 public:
  PublishAckFn fn() {
    return [this](const planet::PublishAck& ack) { add(ack); };
  }
};

TEST(EventBus, SequencesAcknowledgesAndDeliversInOrder) {
  ManualClock clock;
  EventBus bus("", {}, clock);
  EventCollector all;
  EventCollector robot1;
  bus.subscribe(1, subscribe_to(10, "#"), all.deliver(), all.ack());
  bus.subscribe(1, subscribe_to(11, "robot1/*"), robot1.deliver(), robot1.ack());
  Acks acks;
  for (int i = 0; i < 100; ++i)
    bus.publish(event_on(i % 2 == 0 ? "robot1/pose" : "robot2/pose", std::to_string(i)), acks.fn());
  bus.flush();
  auto got = acks.get();
  ASSERT_EQ(got.size(), 100u);
  for (size_t i = 0; i < got.size(); ++i) {
    EXPECT_EQ(got[i].status(), planet::OK);
    EXPECT_EQ(got[i].seq(), i + 1);
  }
  ASSERT_TRUE(all.wait_events(100));
  auto events = all.events();
  for (size_t i = 0; i < events.size(); ++i) {
    EXPECT_EQ(events[i].seq(), i + 1);
    EXPECT_EQ(events[i].subscription_id(), 10u);
    EXPECT_EQ(events[i].payload(), std::to_string(i));
    EXPECT_EQ(events[i].source(), "tester");
    EXPECT_EQ(events[i].time_unix_ns(), clock.now_unix_ns());
  }
  ASSERT_EQ(robot1.events().size(), 50u);
  EXPECT_EQ(robot1.events()[1].seq(), 3u);
  EXPECT_EQ(robot1.events()[1].subscription_id(), 11u);
  EXPECT_EQ(bus.last_seq(), 100u);
}

TEST(EventBus, DuplicatePublishIsAckedWithOriginalSeqAndNotRedelivered) {
  ManualClock clock;
  EventBus bus("", {}, clock);
  EventCollector sub;
  bus.subscribe(1, subscribe_to(1, "a/#"), sub.deliver(), sub.ack());
  Acks acks;
  bus.publish(event_on("a/x", "one", 1, 1), acks.fn());
  bus.publish(event_on("a/x", "two", 1, 2), acks.fn());
  bus.publish(event_on("a/x", "one again", 1, 1), acks.fn());  // resent after a reconnect
  bus.publish(event_on("a/x", "other session", 2, 1), acks.fn());
  bus.flush();
  auto got = acks.get();
  ASSERT_EQ(got.size(), 4u);
  EXPECT_EQ(got[0].seq(), 1u);
  EXPECT_EQ(got[1].seq(), 2u);
  EXPECT_EQ(got[2].seq(), 1u);
  EXPECT_EQ(got[2].publish_id(), 1u);
  EXPECT_EQ(got[2].status(), planet::OK);
  EXPECT_EQ(got[3].seq(), 3u);
  auto events = sub.events();
  ASSERT_EQ(events.size(), 3u);
  EXPECT_EQ(events[2].payload(), "other session");
}

// The publishing sessions remembered for de-duplication are kept in fair shares: a credential
// publishing from many sessions pushes out only its own, so another's resend is still known.
TEST(EventBus, OneCredentialsPublishingSessionsNeverPushOutAnothersIds) {
  ManualClock clock;
  EventBusOptions options;
  options.max_publishers = 8;
  options.max_publishers_per_credential = 4;
  EventBus bus("", options, clock);
  Acks acks;
  PublishInput victim = event_on("a/x", "victim", 1, 1);
  victim.source = "viewer";
  bus.publish(victim, acks.fn());
  for (uint64_t session = 100; session < 150; ++session) {
    PublishInput churn = event_on("a/churn", "x", session, 1);
    churn.source = "mallory";
    bus.publish(churn, acks.fn());
  }
  victim.payload = "victim again";  // resent after a reconnect
  bus.publish(victim, acks.fn());
  PublishInput forgotten = event_on("a/churn", "x", 100, 1);  // mallory's first session: its own went
  forgotten.source = "mallory";
  bus.publish(forgotten, acks.fn());
  bus.flush();
  auto got = acks.get();
  ASSERT_EQ(got.size(), 53u);
  EXPECT_EQ(got[51].status(), planet::OK);
  EXPECT_EQ(got[51].seq(), got[0].seq()) << "the victim's resend was taken for a new event";
  EXPECT_NE(got[52].seq(), got[1].seq());  // mallory's oldest session was forgotten: delivered again
}

TEST(EventBus, ResumeReplaysThenGoesLiveWithoutGapOrDuplicate) {
  ManualClock clock;
  EventBus bus("", {}, clock);
  for (int i = 0; i < 50; ++i) bus.publish(event_on("t/x", std::to_string(i)), nullptr);
  bus.flush();
  // A publisher keeps going while the subscriber resumes.
  std::atomic<bool> stop{false};
  std::thread publisher([&] {
    for (int i = 50; i < 2000 && !stop; ++i) bus.publish(event_on("t/x", std::to_string(i)), nullptr);
  });
  EventCollector sub;
  bus.subscribe(1, subscribe_to(5, "t/#", 20), sub.deliver(), sub.ack());
  publisher.join();
  bus.flush();
  ASSERT_TRUE(sub.wait_ack());
  auto ack = sub.acks()[0];
  EXPECT_EQ(ack.status(), planet::OK);
  EXPECT_EQ(ack.oldest_retained_seq(), 1u);
  EXPECT_GE(ack.last_seq(), 50u);
  auto events = sub.events();
  ASSERT_EQ(events.size(), 2000u - 20u);
  for (size_t i = 0; i < events.size(); ++i) ASSERT_EQ(events[i].seq(), 21 + i) << "at " << i;
}

TEST(EventBus, SubscribeWithoutResumeGetsOnlyNewEvents) {
  ManualClock clock;
  EventBus bus("", {}, clock);
  bus.publish(event_on("t/x", "old"), nullptr);
  EventCollector sub;
  bus.subscribe(1, subscribe_to(1, "t/x"), sub.deliver(), sub.ack());
  bus.publish(event_on("t/x", "new"), nullptr);
  bus.flush();
  ASSERT_EQ(sub.events().size(), 1u);
  EXPECT_EQ(sub.events()[0].payload(), "new");
  EXPECT_EQ(sub.acks()[0].last_seq(), 1u);
}

TEST(EventBus, RetentionIsBoundedAndAGapIsReported) {
  ManualClock clock;
  EventBusOptions options;
  options.retention = 3;
  EventBus bus("", options, clock);
  for (int i = 1; i <= 10; ++i) bus.publish(event_on("t/x", std::to_string(i)), nullptr);
  bus.flush();
  EXPECT_EQ(bus.oldest_retained_seq(), 8u);
  EventCollector sub;
  bus.subscribe(1, subscribe_to(1, "t/x", 2), sub.deliver(), sub.ack());
  bus.flush();
  auto ack = sub.acks().at(0);
  EXPECT_EQ(ack.oldest_retained_seq(), 8u);  // > resume_after + 1: events 3..7 are lost
  EXPECT_EQ(ack.last_seq(), 10u);
  auto events = sub.events();
  ASSERT_EQ(events.size(), 3u);
  EXPECT_EQ(events[0].seq(), 8u);
  EXPECT_EQ(events[2].seq(), 10u);
}

TEST(EventBus, InvalidPatternAndTopicAreRefusedPrecisely) {
  ManualClock clock;
  EventBus bus("", {}, clock);
  EventCollector sub;
  bus.subscribe(1, subscribe_to(3, "a/#/b"), sub.deliver(), sub.ack());
  Acks acks;
  bus.publish(event_on("a/*", "x", 7, 4), acks.fn());
  bus.flush();
  auto ack = sub.acks().at(0);
  EXPECT_EQ(ack.subscription_id(), 3u);
  EXPECT_EQ(ack.status(), planet::BAD_ARGUMENTS);
  EXPECT_EQ(ack.message(), "invalid pattern 'a/#/b': '#' is only allowed as the last level");
  auto refused = acks.get().at(0);
  EXPECT_EQ(refused.publish_id(), 4u);
  EXPECT_EQ(refused.seq(), 0u);
  EXPECT_EQ(refused.status(), planet::BAD_ARGUMENTS);
  EXPECT_EQ(refused.message(), "event on 'a/*' not accepted: the topic is not valid: level 2 ('*') holds a wildcard");
  EXPECT_EQ(bus.last_seq(), 0u);
}

TEST(EventBus, DuplicateSubscriptionIdIsRefusedAndUnsubscribeStopsDelivery) {
  ManualClock clock;
  EventBus bus("", {}, clock);
  EventCollector first;
  EventCollector second;
  bus.subscribe(1, subscribe_to(1, "a"), first.deliver(), first.ack());
  bus.subscribe(1, subscribe_to(1, "b"), second.deliver(), second.ack());
  bus.publish(event_on("a", "1"), nullptr);
  bus.unsubscribe(1, 1);
  bus.publish(event_on("a", "2"), nullptr);
  bus.flush();
  EXPECT_EQ(second.acks().at(0).status(), planet::ALREADY_EXISTS);
  EXPECT_EQ(second.acks().at(0).message(), "subscription 1 already exists on this session");
  ASSERT_EQ(first.events().size(), 1u);
  EXPECT_EQ(first.events()[0].payload(), "1");
}

TEST(EventBus, ReceiverGoneEndsTheSubscription) {
  ManualClock clock;
  EventBus bus("", {}, clock);
  int calls = 0;
  bus.subscribe(
      1, subscribe_to(1, "a"), [&calls](const planet::Event&) { return ++calls < 0; }, nullptr);
  bus.publish(event_on("a", "1"), nullptr);
  bus.publish(event_on("a", "2"), nullptr);
  bus.flush();
  EXPECT_EQ(calls, 1);
}

TEST(EventBus, SeqSurvivesRestartAndRetainedEventsReplay) {
  TempDir dir;
  ManualClock clock;
  {
    EventBus bus(dir.file("events.db"), {}, clock);
    for (int i = 0; i < 3; ++i) bus.publish(event_on("t/x", std::to_string(i)), nullptr);
    bus.flush();
  }
  EventBus bus(dir.file("events.db"), {}, clock);
  EXPECT_EQ(bus.last_seq(), 3u);
  Acks acks;
  bus.publish(event_on("t/x", "after restart"), acks.fn());
  bus.flush();
  EXPECT_EQ(acks.get().at(0).seq(), 4u);
  EventCollector sub;
  bus.subscribe(1, subscribe_to(1, "t/x", 1), sub.deliver(), sub.ack());
  bus.flush();
  auto events = sub.events();
  ASSERT_EQ(events.size(), 3u);
  EXPECT_EQ(events[0].seq(), 2u);
  EXPECT_EQ(events[0].payload(), "1");
  EXPECT_EQ(events[2].payload(), "after restart");
}

TEST(EventBus, InternalSubscriptionsReplayFromZeroAndSinkPublishes) {
  ManualClock clock;
  EventBus bus("", {}, clock);
  BusEventSink sink(bus);
  camus::ServiceInfo info;
  info.set_name("x");
  ASSERT_TRUE(sink.publish("registry/x", info).ok());
  bus.flush();
  EventCollector sub;
  uint64_t handle = bus.subscribe_internal(TopicPattern::parse("registry/#").value(), 0, sub.deliver());
  ASSERT_TRUE(sub.wait_events(1));
  EXPECT_EQ(sub.events()[0].content_type(), "urs.camus.ServiceInfo");
  EXPECT_EQ(sub.events()[0].source(), "camus-server");
  bus.unsubscribe_internal(handle);
  ASSERT_TRUE(sink.publish("registry/x", info).ok());
  bus.flush();
  EXPECT_EQ(sub.events().size(), 1u);
}

TEST(EventBus, StoppedBusRefusesPublishes) {
  ManualClock clock;
  EventBus bus("", {}, clock);
  bus.stop();
  Acks acks;
  EXPECT_FALSE(bus.publish(event_on("a", "late"), acks.fn()));
  ASSERT_EQ(acks.get().size(), 1u);
  EXPECT_EQ(acks.get()[0].status(), planet::UNAVAILABLE);
  EXPECT_EQ(acks.get()[0].message(), "event on 'a' not accepted: server is shutting down");
  bus.flush();  // returns at once
}

TEST(EventBus, ServerTopicsArePublishedByTheServerAlone) {
  ManualClock clock;
  EventBus bus("", {}, clock);
  EventCollector sub;
  bus.subscribe(1, subscribe_to(1, "#"), sub.deliver(), sub.ack());
  Acks acks;
  for (const char* topic : {"registry/diag", "context/robot1/pose", "task/square/r1", "registry"}) {
    EXPECT_FALSE(bus.publish(event_on(topic, "forged", 5, 1), acks.fn()));
  }
  bus.flush();
  auto got = acks.get();
  ASSERT_EQ(got.size(), 4u);
  for (const auto& ack : got) EXPECT_EQ(ack.status(), planet::PERMISSION_DENIED);
  EXPECT_EQ(got[0].message(),
            "event on 'registry/diag' not accepted: topics under 'registry/' are published by the server alone "
            "(registry/, context/ and task/ are server topics)");
  PublishInput real = event_on("registry/diag", "real");
  real.source = kServerPeerName;  // the server itself
  EXPECT_TRUE(bus.publish(real, nullptr));
  // Anyone else without a session (a task, publishing as its owner) is held to the same rule.
  EXPECT_FALSE(bus.publish(event_on("registry/diag", "from a task"), acks.fn()));
  EXPECT_TRUE(bus.publish(event_on("registryx/diag", "fine", 5, 2), nullptr));
  ASSERT_TRUE(sub.wait_events(2));
  EXPECT_EQ(sub.events()[0].payload(), "real");
}

TEST(EventBus, PublishIdZeroOfASessionIsRefused) {
  ManualClock clock;
  EventBus bus("", {}, clock);
  Acks acks;
  EXPECT_FALSE(bus.publish(event_on("a", "x", 5, 0), acks.fn()));
  ASSERT_EQ(acks.get().size(), 1u);
  EXPECT_EQ(acks.get()[0].status(), planet::BAD_ARGUMENTS);
  EXPECT_EQ(acks.get()[0].message(),
            "event on 'a' not accepted: publish_id 0 is not valid: number the publishes of a session from 1");
}

TEST(EventBus, DeduplicationWindowAnswersOldIdsWithoutDeliveringThemAgain) {
  ManualClock clock;
  EventBusOptions options;
  options.dedupe_window = 3;
  EventBus bus("", options, clock);
  EventCollector sub;
  bus.subscribe(1, subscribe_to(1, "a"), sub.deliver(), sub.ack());
  Acks acks;
  for (uint64_t id : {1, 2, 4, 5}) bus.publish(event_on("a", std::to_string(id), 9, id), acks.fn());
  // The window now holds ids 2, 4 and 5.
  bus.publish(event_on("a", "5 again", 9, 5), acks.fn());  // in the window: the original seq
  bus.publish(event_on("a", "1 again", 9, 1), acks.fn());  // older than the window
  bus.publish(event_on("a", "3 late", 9, 3), acks.fn());   // in the window's range, never accepted: a gap filled
  bus.flush();
  auto got = acks.get();
  ASSERT_EQ(got.size(), 7u);
  EXPECT_EQ(got[4].status(), planet::OK);
  EXPECT_EQ(got[4].seq(), got[3].seq());
  EXPECT_EQ(got[5].status(), planet::ALREADY_EXISTS);
  EXPECT_EQ(got[5].seq(), 0u);
  EXPECT_EQ(got[5].message(),
            "publish_id 1 is older than the de-duplication window (the newest 3 ids of this session); it was "
            "accepted or refused before and is not delivered again");
  EXPECT_EQ(got[6].status(), planet::OK);
  EXPECT_EQ(got[6].seq(), 5u);
  ASSERT_TRUE(sub.wait_events(5));
  EXPECT_EQ(sub.events().size(), 5u);
  EXPECT_EQ(sub.events()[4].payload(), "3 late");
}

TEST(EventBus, PublishersAreDeduplicatedApartAndTheLeastRecentIsForgotten) {
  ManualClock clock;
  EventBusOptions options;
  options.max_publishers = 2;
  EventBus bus("", options, clock);
  Acks acks;
  bus.publish(event_on("a", "p1", 1, 1), acks.fn());
  bus.publish(event_on("a", "p2", 2, 1), acks.fn());
  bus.publish(event_on("a", "p3", 3, 1), acks.fn());  // forgets publisher 1
  bus.publish(event_on("a", "p1 again", 1, 1), acks.fn());
  bus.publish(event_on("a", "p3 again", 3, 1), acks.fn());
  bus.flush();
  auto got = acks.get();
  ASSERT_EQ(got.size(), 5u);
  EXPECT_EQ(got[3].seq(), 4u);  // no longer known: accepted anew
  EXPECT_EQ(got[4].seq(), 3u);  // still known: the original
}

// Holds the bus thread inside a delivery until released.
class Gate {
 public:
  DeliverFn deliver() {
    return [this](const planet::Event&) {
      std::unique_lock<std::mutex> lock(mutex_);
      entered_ = true;
      cv_.notify_all();
      cv_.wait_for(lock, kWait, [this] { return open_; });
      return true;
    };
  }
  bool wait_entered() {
    std::unique_lock<std::mutex> lock(mutex_);
    return cv_.wait_for(lock, kWait, [this] { return entered_; });
  }
  void open() {
    std::lock_guard<std::mutex> lock(mutex_);
    open_ = true;
    cv_.notify_all();
  }

 private:
  std::mutex mutex_;
  std::condition_variable cv_;
  bool entered_ = false;
  bool open_ = false;
};

// A bus whose thread is held inside the delivery of a first event, on "slow" (publisher 9, id 1),
// until gate.open(). `all` subscribes to everything after the gate's subscription.
struct HeldBus {
  explicit HeldBus(EventBusOptions options, size_t first_payload = 1) : bus("", options, clock) {
    bus.subscribe(1, subscribe_to(1, "slow"), gate.deliver(), nullptr);
    bus.subscribe(2, subscribe_to(1, "#"), all.deliver(), all.ack());
    held = bus.publish(event_on("slow", std::string(first_payload, '0'), 9, 1), acks.fn()) && gate.wait_entered();
  }
  ManualClock clock;
  Gate gate;
  EventCollector all;
  Acks acks;
  EventBus bus;  // declared last: stopped before what its callbacks use goes away
  bool held = false;
};

TEST(EventBus, ABusBehindRefusesWithResourceExhaustedAndLosesNothingAcknowledged) {
  EventBusOptions options;
  options.event_queue = 4;
  HeldBus held(options);
  ASSERT_TRUE(held.held);
  EventBus& bus = held.bus;
  Acks& acks = held.acks;
  EventCollector& all = held.all;
  Gate& gate = held.gate;
  EXPECT_TRUE(acks.get().empty());  // acknowledged only once delivered
  std::vector<bool> accepted;
  for (uint64_t id = 2; id <= 6; ++id) accepted.push_back(bus.publish(event_on("fast", "x", 9, id), acks.fn()));
  // The first publish is still being processed and counts: 3 more fit, the rest is refused.
  EXPECT_EQ(accepted, (std::vector<bool>{true, true, true, false, false}));
  auto refused = acks.get();
  ASSERT_EQ(refused.size(), 2u);
  EXPECT_EQ(refused[0].status(), planet::RESOURCE_EXHAUSTED);
  EXPECT_EQ(refused[0].message(),
            "event on 'fast' not accepted: the event bus is behind: the server holds 4 operations queued for client "
            "credentials, its limit (event_queue 4 less the 0 kept for sam and operator sessions, reserved_percent "
            "20); credential 'tester' holds 4, over its fair share of 4; retry later");
  gate.open();
  bus.flush();
  size_t ok = 0;
  for (const auto& ack : acks.get()) ok += ack.status() == planet::OK ? 1 : 0;
  EXPECT_EQ(ok, 4u);
  ASSERT_TRUE(all.wait_events(4));
  EXPECT_EQ(all.events().size(), 4u);  // every acknowledged event delivered
}

TEST(EventBus, OneSessionCannotFillTheQueueForOthers) {
  EventBusOptions options;
  options.event_queue = 10;
  options.event_queue_per_session = 3;
  HeldBus held(options);  // publisher 9 has one operation in progress
  ASSERT_TRUE(held.held);
  Acks acks;
  std::vector<bool> flooder;
  for (uint64_t id = 2; id <= 5; ++id) flooder.push_back(held.bus.publish(event_on("x", "f", 9, id), acks.fn()));
  EXPECT_EQ(flooder, (std::vector<bool>{true, true, false, false}));
  EXPECT_EQ(acks.get().at(0).message(),
            "event on 'x' not accepted: the event bus is behind: this session has 3 operations queued "
            "(event_queue_per_session 3); retry later");
  // Another session still gets in, and so do subscribes of another connection.
  EXPECT_TRUE(held.bus.publish(event_on("x", "legit", 5, 1), acks.fn()));
  EventCollector late;
  held.bus.subscribe(77, subscribe_to(1, "x"), late.deliver(), late.ack());
  held.gate.open();
  held.bus.flush();
  EXPECT_EQ(late.acks().at(0).status(), planet::OK);
  EXPECT_EQ(held.bus.publish(event_on("x", "after", 9, 6), acks.fn()), true);  // the share is free again
  held.bus.flush();
}

TEST(EventBus, QueueBytesAreBoundedToo) {
  EventBusOptions options;
  options.event_queue_bytes = 1000;
  HeldBus held(options, 600);
  ASSERT_TRUE(held.held);
  EventBus& bus = held.bus;
  Gate& gate = held.gate;
  Acks acks;
  EXPECT_FALSE(bus.publish(event_on("big", std::string(500, 'x'), 9, 2), acks.fn()));
  EXPECT_EQ(acks.get().at(0).status(), planet::RESOURCE_EXHAUSTED);
  EXPECT_NE(acks.get().at(0).message().find("(event_queue_bytes 1000 less the 200 kept"), std::string::npos)
      << acks.get()[0].message();
  gate.open();
  bus.flush();
}

TEST(EventBus, SubscriptionsAreBoundedPerSessionPerCredentialAndInFairShares) {
  ManualClock clock;
  EventBusOptions options;
  options.max_subscriptions_per_session = 2;
  options.max_subscriptions_per_credential = 3;
  options.max_subscriptions = 5;
  options.reserved_percent = 20;  // 1 of 5 kept for sam and operator sessions
  EventBus bus("", options, clock);
  const planet::ShareHolder mallory{"mallory", false};
  const planet::ShareHolder viewer{"viewer", false};
  const planet::ShareHolder sam{"sam-robot1", true};
  EventCollector sub;
  bus.subscribe(1, subscribe_to(1, "a"), sub.deliver(), sub.ack(), mallory);
  bus.subscribe(1, subscribe_to(2, "b"), sub.deliver(), sub.ack(), mallory);
  bus.subscribe(1, subscribe_to(3, "c"), sub.deliver(), sub.ack(), mallory);  // 3rd on the session
  bus.subscribe(2, subscribe_to(1, "a"), sub.deliver(), sub.ack(), mallory);
  bus.subscribe(3, subscribe_to(1, "a"), sub.deliver(), sub.ack(), mallory);  // 4th of the credential
  bus.subscribe(4, subscribe_to(1, "a"), sub.deliver(), sub.ack(), viewer);
  bus.subscribe(4, subscribe_to(2, "b"), sub.deliver(), sub.ack(), viewer);  // the clients' pool is full,
  bus.subscribe(5, subscribe_to(1, "a"), sub.deliver(), sub.ack(), sam);     // the reserve is not
  bus.subscribe_internal(TopicPattern::parse("#").value(), 0, [](const planet::Event&) { return true; });
  bus.flush();
  auto acks = sub.acks();
  ASSERT_EQ(acks.size(), 8u);
  std::vector<planet::Status> statuses;
  for (const auto& ack : acks) statuses.push_back(ack.status());
  EXPECT_EQ(statuses, (std::vector<planet::Status>{planet::OK, planet::OK, planet::RESOURCE_EXHAUSTED, planet::OK,
                                                   planet::RESOURCE_EXHAUSTED, planet::OK, planet::OK, planet::OK}));
  EXPECT_EQ(acks[2].message(),
            "subscription to 'c' not accepted: this session already has 2 subscriptions "
            "(max_subscriptions_per_session 2)");
  EXPECT_EQ(acks[4].message(),
            "subscription to 'a' not accepted: credential 'mallory' holds 3 subscriptions "
            "(max_subscriptions_per_credential 3)");
  // viewer's second passes the clients' pool (4), within its fair share (2 of 4).
  EXPECT_EQ(bus.subscriptions(), 7u);  // the server's own is not counted against the limits
  bus.subscribe(6, subscribe_to(1, "c"), sub.deliver(), sub.ack(), viewer);
  bus.flush();
  EXPECT_EQ(sub.acks().back().status(), planet::RESOURCE_EXHAUSTED);
  EXPECT_THAT(sub.acks().back().message(),
              ::testing::HasSubstr("credential 'viewer' holds 2, over its fair share of 2"));
  bus.drop_owner(1);
  bus.subscribe(3, subscribe_to(1, "a"), sub.deliver(), sub.ack(), mallory);
  bus.flush();
  EXPECT_EQ(sub.acks().back().status(), planet::OK);
  EXPECT_EQ(bus.subscriptions(), 6u);
}

TEST(EventBus, OversizedPatternsAndTopicsAreRefusedBeforeTheyAreKept) {
  ManualClock clock;
  EventBus bus("", {}, clock);
  EventCollector sub;
  const std::string long_pattern(60 * 1024, 'a');
  std::string deep_pattern = "a";
  for (int i = 1; i < 30000; ++i) deep_pattern += "/a";
  bus.subscribe(1, subscribe_to(1, long_pattern), sub.deliver(), sub.ack());
  bus.subscribe(1, subscribe_to(2, deep_pattern), sub.deliver(), sub.ack());
  Acks acks;
  bus.publish(event_on(deep_pattern, "x", 5, 1), acks.fn());
  bus.flush();
  auto got = sub.acks();
  ASSERT_EQ(got.size(), 2u);
  EXPECT_EQ(got[0].status(), planet::BAD_ARGUMENTS);
  EXPECT_EQ(got[0].message(), "invalid pattern '" + long_pattern.substr(0, 64) +
                                  "...' (61440 bytes): it is 61440 bytes long; the limit is 512 (max_topic_bytes)");
  EXPECT_EQ(got[1].status(), planet::BAD_ARGUMENTS);
  EXPECT_NE(got[1].message().find("it is 59999 bytes long; the limit is 512 (max_topic_bytes)"), std::string::npos);
  EXPECT_EQ(acks.get().at(0).status(), planet::BAD_ARGUMENTS);
  EXPECT_EQ(bus.subscriptions(), 0u);
  // Within the byte limit but over the level limit.
  std::string levels33 = "a";
  for (int i = 1; i < 33; ++i) levels33 += "/a";
  bus.subscribe(1, subscribe_to(3, levels33), sub.deliver(), sub.ack());
  EXPECT_EQ(sub.acks().back().message(), "invalid pattern '" + levels33.substr(0, 64) +
                                             "...' (65 bytes): it has 33 levels; the limit is 32 (max_topic_levels)");
}

TEST(EventBus, EventsReachOnlyMatchingSubscriptionsAmongManyOthers) {
  ManualClock clock;
  EventBus bus("", {}, clock);
  std::atomic<int> wrong{0};
  for (uint64_t i = 0; i < 2000; ++i) {
    bus.subscribe(
        100 + i / 500, subscribe_to(i, "kr/robot" + std::to_string(i) + "/#"),
        [&wrong](const planet::Event&) {
          ++wrong;
          return true;
        },
        nullptr);
  }
  EventCollector wanted;
  bus.subscribe(1, subscribe_to(1, "kr/*/arrived"), wanted.deliver(), wanted.ack());
  EventCollector robot7;
  bus.subscribe(2, subscribe_to(1, "kr/robot7/#"), robot7.deliver(), robot7.ack());
  for (int i = 0; i < 100; ++i) bus.publish(event_on("kr/robotX/arrived", std::to_string(i)), nullptr);
  bus.publish(event_on("kr/robot7/arrived", "seven"), nullptr);
  bus.flush();
  EXPECT_EQ(wanted.events().size(), 101u);
  EXPECT_EQ(robot7.events().size(), 1u);
  EXPECT_EQ(wrong.load(), 1);  // only "kr/robot7/#" of the 2,000 matched, once
}

}  // namespace
}  // namespace urs::camus_server::test
