// The client's table of calls in flight: queueing while disconnected, deadlines, at most once.

#include "client/pending_calls.hpp"

#include <gtest/gtest.h>

#include <optional>
#include <string>

#include "recording_sink.hpp"

namespace urs::planet::detail {
namespace {

using std::chrono::milliseconds;

constexpr const char* kTarget = "example.org:7000";

Request request(const std::string& operation, bool oneway = false) {
  Request out;
  out.set_service("svc");
  out.set_operation(operation);
  out.set_payload("x");
  out.set_oneway(oneway);
  return out;
}

// Captures one call's result.
struct Outcome {
  std::optional<CallResult> result;
  ReplyHandler handler() {
    return [this](CallResult r) { result = std::move(r); };
  }
};

class PendingCallsTest : public ::testing::Test {
 protected:
  Reply reply_to(const Frame& frame, Status status = Status::OK) {
    Reply reply;
    reply.set_call_id(frame.request().call_id());
    reply.set_status(status);
    reply.set_payload("answer");
    return reply;
  }

  asio::io_context io;
  QueueBudget budget{100, kTarget};
  PendingCalls calls{io, kTarget, milliseconds(60000), budget};
  std::shared_ptr<RecordingSink> sink = std::make_shared<RecordingSink>();
  Deferred out;
};

TEST_F(PendingCallsTest, QueuedCallsGoOutInOrderWhenASessionOpensAndTheirReplyCompletesThem) {
  Outcome first, second;
  EXPECT_TRUE(calls.start(request("a"), milliseconds(0), first.handler(), out));
  EXPECT_TRUE(calls.start(request("b"), milliseconds(0), second.handler(), out));
  EXPECT_EQ(budget.used(), 2u);
  calls.open(sink, UINT64_MAX);
  EXPECT_TRUE(sink->frames().empty()) << "queued calls wait for flush()";
  calls.flush(out);
  const auto frames = sink->frames();
  ASSERT_EQ(frames.size(), 2u);
  EXPECT_EQ(frames[0].request().operation(), "a");
  EXPECT_EQ(frames[1].request().operation(), "b");
  EXPECT_EQ(frames[0].request().deadline_ms(), 0u) << "no deadline: the server's applies";
  EXPECT_EQ(budget.used(), 0u);

  calls.on_reply(reply_to(frames[1]), out);
  run_all(out);
  ASSERT_TRUE(second.result);
  EXPECT_TRUE(second.result->ok());
  EXPECT_EQ(second.result->payload, "answer");
  EXPECT_FALSE(first.result);
  EXPECT_EQ(calls.size(), 1u);
}

TEST_F(PendingCallsTest, ACallGivenADeadlineFailsWhenItPassesWhileQueued) {
  Outcome outcome;
  calls.start(request("slow"), milliseconds(20), outcome.handler(), out);
  io.run();  // until the deadline timer fired
  ASSERT_TRUE(outcome.result);
  EXPECT_EQ(outcome.result->status, Status::DEADLINE_EXCEEDED);
  EXPECT_EQ(outcome.result->message, "no reply from svc.slow within 20 ms");
  EXPECT_EQ(calls.size(), 0u);
  EXPECT_EQ(budget.used(), 0u);
  calls.open(sink, UINT64_MAX);
  calls.flush(out);
  EXPECT_TRUE(sink->frames().empty()) << "an expired call is never sent";
}

TEST_F(PendingCallsTest, ACallGivenADeadlineFailsWhenItPassesAfterBeingSentAndALateReplyIsIgnored) {
  calls.open(sink, UINT64_MAX);
  calls.flush(out);
  Outcome outcome;
  calls.start(request("slow"), milliseconds(20), outcome.handler(), out);
  const auto frames = sink->frames();
  ASSERT_EQ(frames.size(), 1u);
  EXPECT_GE(frames[0].request().deadline_ms(), 1u);
  EXPECT_LE(frames[0].request().deadline_ms(), 20u) << "what is left of the deadline travels";
  io.run();
  ASSERT_TRUE(outcome.result);
  EXPECT_EQ(outcome.result->status, Status::DEADLINE_EXCEEDED);
  outcome.result.reset();
  calls.on_reply(reply_to(frames[0]), out);
  run_all(out);
  EXPECT_FALSE(outcome.result) << "the handler runs exactly once";
}

TEST_F(PendingCallsTest, WithoutADeadlineOnlyTheWaitForAConnectionIsBounded) {
  PendingCalls short_wait(io, kTarget, milliseconds(20), budget);
  Outcome queued;
  short_wait.start(request("queued"), milliseconds(0), queued.handler(), out);
  io.run();
  ASSERT_TRUE(queued.result);
  EXPECT_EQ(queued.result->status, Status::UNAVAILABLE);
  EXPECT_EQ(queued.result->message, "svc.queued not sent: no connection to example.org:7000 within 20 ms");

  // Once sent, the server's answer bounds it: the local timer leaves it alone.
  io.restart();
  short_wait.open(sink, UINT64_MAX);
  short_wait.flush(out);
  Outcome sent;
  short_wait.start(request("sent"), milliseconds(0), sent.handler(), out);
  io.run();
  EXPECT_FALSE(sent.result);
  short_wait.on_reply(reply_to(sink->frames().at(0), Status::DEADLINE_EXCEEDED), out);
  run_all(out);
  ASSERT_TRUE(sent.result);
  EXPECT_EQ(sent.result->status, Status::DEADLINE_EXCEEDED);
}

TEST_F(PendingCallsTest, SentCallsFailWhenTheSessionClosesAndQueuedOnesWaitForTheNext) {
  calls.open(sink, UINT64_MAX);
  calls.flush(out);
  Outcome sent, kept;
  calls.start(request("sent"), milliseconds(0), sent.handler(), out);
  sink->refuse(true);  // the connection is closing
  calls.start(request("kept"), milliseconds(0), kept.handler(), out);
  calls.detach(out);
  run_all(out);
  ASSERT_TRUE(sent.result);
  EXPECT_EQ(sent.result->status, Status::UNAVAILABLE);
  EXPECT_EQ(sent.result->message, "connection to server lost");
  EXPECT_FALSE(kept.result);

  auto next = std::make_shared<RecordingSink>();
  calls.open(next, UINT64_MAX);
  calls.flush(out);
  ASSERT_EQ(next->frames().size(), 1u) << "at most once: only the call that never went out is sent";
  EXPECT_EQ(next->frames()[0].request().operation(), "kept");
}

TEST_F(PendingCallsTest, WhileASessionIsRestoredOnlyCallsStartedFirstGoOut) {
  Outcome queued, registration;
  calls.start(request("queued"), milliseconds(0), queued.handler(), out);
  calls.open(sink, UINT64_MAX);
  calls.start(request("Register"), milliseconds(0), registration.handler(), out, /*first=*/true);
  calls.start(request("later"), milliseconds(0), nullptr, out);
  calls.flush(out);
  const auto frames = sink->frames();
  ASSERT_EQ(frames.size(), 3u);
  EXPECT_EQ(frames[0].request().operation(), "Register");
  EXPECT_EQ(frames[1].request().operation(), "queued");
  EXPECT_EQ(frames[2].request().operation(), "later");
}

TEST_F(PendingCallsTest, RefusesWhenDisconnectedAndTheBudgetIsFull) {
  QueueBudget small(1, kTarget);
  PendingCalls small_queue(io, kTarget, milliseconds(60000), small);
  Outcome first, second;
  EXPECT_TRUE(small_queue.start(request("a"), milliseconds(0), first.handler(), out));
  EXPECT_FALSE(small_queue.start(request("b"), milliseconds(0), second.handler(), out));
  EXPECT_FALSE(small_queue.start(request("oneway", true), milliseconds(0), nullptr, out));
  run_all(out);
  ASSERT_TRUE(second.result);
  EXPECT_EQ(second.result->status, Status::UNAVAILABLE);
  EXPECT_EQ(second.result->message, "not connected to example.org:7000 and the queue of 1 is full");
}

TEST_F(PendingCallsTest, ARequestTooLargeForTheServerFailsWithoutBeingSent) {
  calls.open(sink, 10);
  calls.flush(out);
  Outcome outcome;
  Request big = request("big");
  big.set_payload(std::string(100, 'p'));
  calls.start(std::move(big), milliseconds(0), outcome.handler(), out);
  run_all(out);
  ASSERT_TRUE(outcome.result);
  EXPECT_EQ(outcome.result->status, Status::PAYLOAD_TOO_LARGE);
  EXPECT_TRUE(sink->frames().empty());
  EXPECT_EQ(calls.size(), 0u);
}

TEST_F(PendingCallsTest, OnewaysAreForgottenOnceSent) {
  calls.open(sink, UINT64_MAX);
  calls.flush(out);
  EXPECT_TRUE(calls.start(request("fire", true), milliseconds(0), nullptr, out));
  EXPECT_EQ(sink->frames().size(), 1u);
  EXPECT_EQ(calls.size(), 0u);
}

TEST_F(PendingCallsTest, CloseFailsEverythingAndRefusesLaterCalls) {
  Outcome queued, later;
  calls.start(request("queued"), milliseconds(0), queued.handler(), out);
  calls.close("client stopped", out);
  EXPECT_FALSE(calls.start(request("later"), milliseconds(0), later.handler(), out));
  run_all(out);
  ASSERT_TRUE(queued.result);
  EXPECT_EQ(queued.result->message, "client stopped");
  ASSERT_TRUE(later.result);
  EXPECT_EQ(later.result->status, Status::UNAVAILABLE);
  EXPECT_EQ(budget.used(), 0u);
}

}  // namespace
}  // namespace urs::planet::detail
