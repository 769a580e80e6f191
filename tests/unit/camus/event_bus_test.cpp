#include "urs/camus_server/event_bus.hpp"

#include <gtest/gtest.h>

#include <thread>

#include "fakes.hpp"

namespace urs::camus_server::test {
namespace {

PublishInput event_on(const std::string& topic, const std::string& payload, const std::string& key = "",
                      uint64_t publish_id = 0) {
  PublishInput in;
  in.topic = topic;
  in.payload = payload;
  in.content_type = "text/plain";
  in.source = "tester";
  in.session_key = key;
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

class Acks {
 public:
  PublishAckFn fn() {
    return [this](const planet::PublishAck& ack) {
      std::lock_guard<std::mutex> lock(mutex_);
      acks_.push_back(ack);
    };
  }
  std::vector<planet::PublishAck> get() {
    std::lock_guard<std::mutex> lock(mutex_);
    return acks_;
  }

 private:
  std::mutex mutex_;
  std::vector<planet::PublishAck> acks_;
};

TEST(EventBus, SequencesAcknowledgesAndDeliversInOrder) {
  ManualClock clock;
  EventBus bus("", {}, clock);
  EventCollector all;
  EventCollector robot1;
  bus.subscribe(1, subscribe_to(10, "#"), all.deliver(), all.ack());
  bus.subscribe(1, subscribe_to(11, "robot1/*"), robot1.deliver(), robot1.ack());
  Acks acks;
  for (int i = 0; i < 100; ++i) bus.publish(event_on(i % 2 == 0 ? "robot1/pose" : "robot2/pose", std::to_string(i)), acks.fn());
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
  bus.publish(event_on("a/x", "one", "session-A", 1), acks.fn());
  bus.publish(event_on("a/x", "two", "session-A", 2), acks.fn());
  bus.publish(event_on("a/x", "one again", "session-A", 1), acks.fn());  // resent after a reconnect
  bus.publish(event_on("a/x", "other session", "session-B", 1), acks.fn());
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
  bus.publish(event_on("a/*", "x", "s", 4), acks.fn());
  bus.flush();
  auto ack = sub.acks().at(0);
  EXPECT_EQ(ack.subscription_id(), 3u);
  EXPECT_EQ(ack.status(), planet::BAD_ARGUMENTS);
  EXPECT_EQ(ack.message(), "invalid pattern 'a/#/b': '#' is only allowed as the last level");
  auto refused = acks.get().at(0);
  EXPECT_EQ(refused.publish_id(), 4u);
  EXPECT_EQ(refused.seq(), 0u);
  EXPECT_EQ(refused.status(), planet::BAD_ARGUMENTS);
  EXPECT_EQ(refused.message(), "topic 'a/*' is not valid: level 2 ('*') holds a wildcard");
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
  bus.subscribe(1, subscribe_to(1, "a"), [&calls](const planet::Event&) { return ++calls < 0; }, nullptr);
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

}  // namespace
}  // namespace urs::camus_server::test
