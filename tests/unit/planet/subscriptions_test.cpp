// The client's subscriptions: resumed after the last event on every session, duplicates dropped,
// and unsubscribe() waiting for a running handler.

#include "client/subscriptions.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <future>
#include <thread>
#include <vector>

#include "recording_sink.hpp"

namespace urs::planet::detail {
namespace {

Event event(uint64_t subscription, uint64_t seq) {
  Event out;
  out.set_subscription_id(subscription);
  out.set_seq(seq);
  out.set_topic("t/x");
  return out;
}

TEST(Subscriptions, ResumesAfterTheLastEventAndDeliversAReplayOnce) {
  Subscriptions subscriptions("example.org:7000");
  std::vector<uint64_t> seen;
  const uint64_t id = subscriptions.subscribe(
      "t/*", [&](const Event& e) { seen.push_back(e.seq()); }, 0);
  auto first = std::make_shared<RecordingSink>();
  subscriptions.open(first);
  ASSERT_EQ(first->frames().size(), 1u);
  EXPECT_EQ(first->frames()[0].subscribe().pattern(), "t/*");
  EXPECT_EQ(first->frames()[0].subscribe().resume_after_seq(), 0u);

  SubscribeAck ack;
  ack.set_subscription_id(id);
  ack.set_status(Status::OK);
  ack.set_last_seq(10);  // "only new events": from after 10
  subscriptions.on_ack(ack);
  subscriptions.on_event(event(id, 10));
  subscriptions.on_event(event(id, 11));
  subscriptions.on_event(event(id, 12));

  subscriptions.detach();
  auto second = std::make_shared<RecordingSink>();
  subscriptions.open(second);
  ASSERT_EQ(second->frames().size(), 1u);
  EXPECT_EQ(second->frames()[0].subscribe().resume_after_seq(), 12u);
  subscriptions.on_event(event(id, 12));  // replayed
  subscriptions.on_event(event(id, 13));
  EXPECT_EQ(seen, (std::vector<uint64_t>{11, 12, 13}));
}

TEST(Subscriptions, UnsubscribeTellsTheServerAndDropsLaterEvents) {
  Subscriptions subscriptions("example.org:7000");
  auto sink = std::make_shared<RecordingSink>();
  subscriptions.open(sink);
  int calls = 0;
  const uint64_t id = subscriptions.subscribe(
      "t/*", [&](const Event&) { ++calls; }, 0);
  subscriptions.unsubscribe(id);
  subscriptions.on_event(event(id, 1));
  EXPECT_EQ(calls, 0);
  ASSERT_EQ(sink->frames().size(), 2u);
  EXPECT_EQ(sink->frames()[1].unsubscribe().subscription_id(), id);
}

TEST(Subscriptions, UnsubscribeReturnsOnlyOnceTheRunningHandlerReturned) {
  Subscriptions subscriptions("example.org:7000");
  auto sink = std::make_shared<RecordingSink>();
  subscriptions.open(sink);
  std::promise<void> entered;
  std::atomic<bool> handler_done{false};
  const uint64_t id = subscriptions.subscribe(
      "t/*",
      [&](const Event&) {
        entered.set_value();
        sink->wait_for_frames(2);  // the Subscribe, then unsubscribe()'s Unsubscribe: it is waiting
        handler_done = true;
      },
      0);
  std::thread io([&] { subscriptions.on_event(event(id, 1)); });
  entered.get_future().wait();
  subscriptions.unsubscribe(id);
  EXPECT_TRUE(handler_done.load());
  io.join();
}

TEST(Subscriptions, AHandlerMayUnsubscribeItself) {
  Subscriptions subscriptions("example.org:7000");
  uint64_t id = 0;
  int calls = 0;
  id = subscriptions.subscribe(
      "t/*",
      [&](const Event&) {
        ++calls;
        subscriptions.unsubscribe(id);
      },
      0);
  subscriptions.on_event(event(id, 1));
  subscriptions.on_event(event(id, 2));
  EXPECT_EQ(calls, 1);
}

}  // namespace
}  // namespace urs::planet::detail
