// The client's publishes until acknowledged: kept while disconnected, resent after a reconnect
// until the server acknowledges them (at least once), bounded with the calls by one budget.

#include "client/publish_queue.hpp"

#include <gtest/gtest.h>

#include <future>
#include <thread>

#include "recording_sink.hpp"

namespace urs::planet::detail {
namespace {

using std::chrono::milliseconds;

constexpr const char* kTarget = "example.org:7000";

PublishAck ack_of(const Frame& frame, Status status = Status::OK) {
  PublishAck ack;
  ack.set_publish_id(frame.publish().publish_id());
  ack.set_status(status);
  if (status != Status::OK) ack.set_message("bad topic");
  return ack;
}

TEST(PublishQueue, KeepsPublishesUntilAcknowledgedAndResendsThemInOrderAfterAReconnect) {
  QueueBudget budget(100, kTarget);
  PublishQueue queue(budget);
  ASSERT_TRUE(queue.publish("t/a", "1", "text/plain").ok());  // disconnected: kept
  auto first = std::make_shared<RecordingSink>();
  queue.open(first, UINT64_MAX);
  ASSERT_TRUE(queue.publish("t/b", "2", "text/plain").ok());  // connected: sent at once
  auto sent = first->frames();
  ASSERT_EQ(sent.size(), 2u);
  EXPECT_EQ(sent[0].publish().topic(), "t/a");
  EXPECT_EQ(sent[1].publish().topic(), "t/b");

  queue.on_ack(ack_of(sent[0]));
  EXPECT_EQ(queue.unacknowledged(), 1u);
  EXPECT_EQ(budget.used(), 1u);

  // The session is lost before t/b's ack: the next one sends it again, with the same id.
  queue.detach();
  auto second = std::make_shared<RecordingSink>();
  queue.open(second, UINT64_MAX);
  const auto resent = second->frames();
  ASSERT_EQ(resent.size(), 1u);
  EXPECT_EQ(resent[0].publish().topic(), "t/b");
  EXPECT_EQ(resent[0].publish().publish_id(), sent[1].publish().publish_id());

  queue.on_ack(ack_of(resent[0]));
  queue.on_ack(ack_of(sent[1]));  // a duplicate ack changes nothing
  EXPECT_EQ(queue.unacknowledged(), 0u);
  EXPECT_EQ(budget.used(), 0u);
}

TEST(PublishQueue, SharesItsBoundWithTheCallsAndSaysWhatFillsIt) {
  QueueBudget budget(2, kTarget);
  PublishQueue queue(budget);
  budget.take();  // a queued call
  ASSERT_TRUE(queue.publish("t", "1", "").ok());
  CallResult refused = queue.publish("t", "2", "");
  EXPECT_EQ(refused.status, Status::UNAVAILABLE);
  EXPECT_EQ(refused.message, "not connected to example.org:7000 and the queue of 2 is full");
  queue.open(std::make_shared<RecordingSink>(), UINT64_MAX);
  refused = queue.publish("t", "3", "");
  EXPECT_EQ(refused.message, "the queue of 2 publishes awaiting acknowledgement from example.org:7000 is full");
}

TEST(PublishQueue, RefusesWhatTheServerWouldNotTakeAndDropsItFromTheQueueOnReconnect) {
  QueueBudget budget(100, kTarget);
  PublishQueue queue(budget);
  ASSERT_TRUE(queue.publish("t", std::string(200, 'p'), "").ok());  // disconnected: no limit known
  auto sink = std::make_shared<RecordingSink>();
  queue.open(sink, 100);
  EXPECT_TRUE(sink->frames().empty());
  EXPECT_EQ(queue.unacknowledged(), 0u);
  EXPECT_EQ(queue.publish("t", std::string(200, 'p'), "").status, Status::PAYLOAD_TOO_LARGE);
  EXPECT_EQ(budget.used(), 0u);
}

TEST(PublishQueue, PublishAndWaitReturnsTheServersAnswer) {
  QueueBudget budget(100, kTarget);
  PublishQueue queue(budget);
  auto sink = std::make_shared<RecordingSink>();
  queue.open(sink, UINT64_MAX);
  auto refused =
      std::async(std::launch::async, [&] { return queue.publish_and_wait("bad topic", "", "", milliseconds(60000)); });
  sink->wait_for_frames(1);
  queue.on_ack(ack_of(sink->frames().at(0), Status::BAD_ARGUMENTS));
  const CallResult result = refused.get();
  EXPECT_EQ(result.status, Status::BAD_ARGUMENTS);
  EXPECT_EQ(result.message, "bad topic");
}

TEST(PublishQueue, PublishAndWaitTimesOutKeepingTheEventAndFailsWhenClosed) {
  QueueBudget budget(100, kTarget);
  PublishQueue queue(budget);
  const CallResult late = queue.publish_and_wait("t", "", "", milliseconds(10));
  EXPECT_EQ(late.status, Status::DEADLINE_EXCEEDED);
  EXPECT_EQ(late.message, "no acknowledgement of the event on 't' within 10 ms");
  EXPECT_EQ(queue.unacknowledged(), 1u) << "the event stays queued";

  auto sink = std::make_shared<RecordingSink>();
  queue.open(sink, UINT64_MAX);
  auto waiting =
      std::async(std::launch::async, [&] { return queue.publish_and_wait("t", "", "", milliseconds(60000)); });
  sink->wait_for_frames(2);  // the first event resent, then this one
  queue.close();
  EXPECT_EQ(waiting.get().status, Status::UNAVAILABLE);
  EXPECT_EQ(queue.publish("t", "", "").message, "client stopped");
  EXPECT_EQ(budget.used(), 0u);
}

}  // namespace
}  // namespace urs::planet::detail
