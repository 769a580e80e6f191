// core::ForwardingAgent on an AgentHost, over an in-memory CallSink: the calls it takes through
// forward() (bytes passed on unparsed both ways, a raised exception checked, the deadline kept),
// and those it leaves to the host's worker path when the sink cannot start them without blocking.

#include "urs/bridge/core/forwarding_agent.hpp"

#include <gtest/gtest.h>

#include <future>
#include <mutex>
#include <optional>
#include <thread>

#include "Diagnostic.pb.h"
#include "urs/agent/agent.hpp"

namespace urs::bridge::core {
namespace {

using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;

// What the sink was handed; a test answers the calls it started through `done`.
struct Sent {
  std::string service;
  std::string operation;
  std::string payload;
  Clock::time_point deadline;
  call::Identity caller;
  bool oneway = false;
  CallSink::Done done;
  bool blocking = false;  // through CallSink::call
};

// The sink a test holds: it records what it is handed, starts calls or not, answers blocking
// calls with `blocking_reply`.
class RecordingSink : public CallSink {
 public:
  bool start(call::Request& request, Done done) override {
    if (!starts) return false;
    record({request.service, request.operation, std::move(request.payload), request.deadline, request.caller,
            request.oneway, std::move(done), false});
    return true;
  }
  call::Reply call(call::Request request) override {
    record({request.service, request.operation, std::move(request.payload), request.deadline, request.caller,
            request.oneway, nullptr, true});
    return blocking_reply;
  }
  std::string to() const override { return "space jp"; }

  std::optional<Sent> sent() {
    std::lock_guard lock(mutex);
    return last;
  }
  void record(Sent sent) {
    std::lock_guard lock(mutex);
    last = std::move(sent);
  }

  bool starts = true;  // whether it starts calls without blocking
  call::Reply blocking_reply = call::Reply::error(call::Status::INTERNAL, "not set");
  std::mutex mutex;
  std::optional<Sent> last;
};

const std::string kGarbage = std::string("\xff\xff\xff", 3) + " not a message";

class Forwarding : public ::testing::Test {
 protected:
  Forwarding() : host_(1, events_) {
    const auto* interface = URS::Diagnostic_echo_Request::descriptor()->file()->FindServiceByName("Diagnostic");
    host_.add({"jp/diag", std::make_shared<ForwardingAgent>(sink_, "diag", *interface), {}, 0});
    host_.start();
  }

  // Dispatches a call; its answer is read with answer().
  void dispatch(const std::string& operation, std::string payload, Clock::time_point deadline = Clock::now() + 2s,
                bool oneway = false) {
    call::Request request;
    request.service = "jp/diag";
    request.operation = operation;
    request.payload = std::move(payload);
    request.deadline = deadline;
    deadline_ = deadline;
    request.caller = {"", "alice", "client"};
    request.oneway = oneway;
    auto promise = std::make_shared<std::promise<call::Reply>>();
    answered_ = promise->get_future();
    host_.dispatch(std::move(request),
                   oneway ? call::Responder() : call::Responder::from_callback([promise](call::Reply reply) {
                     promise->set_value(reply);
                   }));
  }
  bool answered() { return answered_.wait_for(0s) == std::future_status::ready; }
  call::Reply answer() {
    if (answered_.wait_for(5s) != std::future_status::ready)
      return call::Reply::error(call::Status::INTERNAL, "no answer");
    return answered_.get();
  }
  std::optional<Sent> sent() { return sink_->sent(); }
  // The completion of the call the sink started last.
  void reply(call::Reply result) {
    auto done = sent()->done;
    done(std::move(result));
  }

  std::shared_ptr<RecordingSink> sink_ = std::make_shared<RecordingSink>();
  agent::DiscardingEventSink events_;
  agent::AgentHost host_;
  std::future<call::Reply> answered_;
  Clock::time_point deadline_;
};

// The request's bytes reach the route as they came, even bytes that are no request of the
// operation (the far end refuses those), and the reply's come back as they came.
TEST_F(Forwarding, ACallsBytesPassThroughUnparsedBothWays) {
  dispatch("echo", kGarbage);
  const auto to_jp = sent();
  ASSERT_TRUE(to_jp);
  EXPECT_FALSE(to_jp->blocking);
  EXPECT_EQ(to_jp->service, "diag");
  EXPECT_EQ(to_jp->operation, "echo");
  EXPECT_EQ(to_jp->payload, kGarbage);
  EXPECT_EQ(to_jp->deadline, deadline_);
  EXPECT_EQ(to_jp->caller.name, "alice");
  EXPECT_FALSE(to_jp->oneway);
  EXPECT_FALSE(answered()) << "answered before the route's reply";

  const std::string not_a_reply("\xfe\xfe back", 7);
  reply(call::Reply::success(not_a_reply));
  const auto result = answer();
  ASSERT_EQ(result.status, call::Status::OK) << result.message;
  EXPECT_EQ(result.payload, not_a_reply);
}

// The sink answers from its own thread, as a DDS listener or a Planet I/O thread would.
TEST_F(Forwarding, TheReplyIsHandedBackFromTheRoutesThread) {
  dispatch("echo", "bytes");
  std::thread([this] { reply(call::Reply::error(call::Status::PROVIDER_GONE, "the bridge of space jp left")); }).join();
  const auto result = answer();
  EXPECT_EQ(result.status, call::Status::PROVIDER_GONE);
  EXPECT_EQ(result.message, "the bridge of space jp left");
}

TEST_F(Forwarding, ADeclaredExceptionIsCheckedAndHandedBackAnUndeclaredOneRefused) {
  URS::Failure failure;
  failure.set_reason("wheel stuck");
  failure.set_code(12);
  dispatch("fail", "");
  reply(call::Reply::user_exception("URS.Failure", failure.SerializeAsString(), "raised"));
  auto result = answer();
  ASSERT_EQ(result.status, call::Status::USER_EXCEPTION) << result.message;
  EXPECT_EQ(result.exception_type, "URS.Failure");
  EXPECT_EQ(result.message, "raised");
  URS::Failure back;
  ASSERT_TRUE(back.ParseFromString(result.payload));
  EXPECT_EQ(back.reason(), "wheel stuck");
  EXPECT_EQ(back.code(), 12);

  dispatch("echo", "");
  reply(call::Reply::user_exception("URS.Failure", failure.SerializeAsString(), "raised"));
  result = answer();
  EXPECT_EQ(result.status, call::Status::INTERNAL);
  EXPECT_EQ(result.message, "diag.echo raised URS.Failure, which it does not declare");

  dispatch("fail", "");
  reply(call::Reply::user_exception("URS.Failure", kGarbage, "raised"));
  result = answer();
  EXPECT_EQ(result.status, call::Status::INTERNAL);
  EXPECT_EQ(result.message, "diag raised an invalid URS.Failure");
}

TEST_F(Forwarding, ACallWhoseDeadlinePassedIsNotSent) {
  dispatch("echo", "bytes", Clock::now() - 1ms);
  const auto result = answer();
  EXPECT_EQ(result.status, call::Status::DEADLINE_EXCEEDED);
  EXPECT_EQ(result.message, "the caller's deadline passed before diag.echo was sent");
  EXPECT_FALSE(sent());
}

TEST_F(Forwarding, AOnewayCallIsSentAndAnswersNothing) {
  dispatch("notify", kGarbage, Clock::now() + 2s, true);
  const auto to_jp = sent();
  ASSERT_TRUE(to_jp);
  EXPECT_FALSE(to_jp->blocking);
  EXPECT_EQ(to_jp->operation, "notify");
  EXPECT_EQ(to_jp->payload, kGarbage);
  EXPECT_TRUE(to_jp->oneway);
  // Whether it was sent goes nowhere: the caller asked for no answer.
  reply(call::Reply::error(call::Status::UNAVAILABLE, "no bridge of space jp takes it now"));
}

// A twoway call of a oneway operation is answered once the sink says whether it was sent.
TEST_F(Forwarding, AOnewayOperationCalledTwowayIsAnsweredWhetherItWasSent) {
  dispatch("notify", "bytes");
  ASSERT_TRUE(sent());
  EXPECT_TRUE(sent()->oneway);
  reply(call::Reply::error(call::Status::UNAVAILABLE, "no bridge of space jp takes it now"));
  const auto result = answer();
  EXPECT_EQ(result.status, call::Status::UNAVAILABLE);
  EXPECT_EQ(result.message, "diag.notify could not be sent to space jp: no bridge of space jp takes it now");
}

// A call the sink cannot start without blocking is left as it came: the host parses it and runs
// invoke() on a worker, which makes the blocking call.
TEST_F(Forwarding, ACallTheSinkCannotStartRunsOnAWorkerAsBefore) {
  sink_->starts = false;
  dispatch("echo", kGarbage);
  auto result = answer();
  EXPECT_EQ(result.status, call::Status::BAD_ARGUMENTS);
  EXPECT_EQ(result.message, "payload of jp/diag.echo is not a valid URS.Diagnostic_echo_Request");
  EXPECT_FALSE(sent());

  URS::Diagnostic_echo_Request echo;
  echo.set_text("hello");
  URS::Diagnostic_echo_Reply echoed;
  echoed.set_result("hello");
  sink_->blocking_reply = call::Reply::success(echoed.SerializeAsString());
  dispatch("echo", echo.SerializeAsString());
  result = answer();
  ASSERT_EQ(result.status, call::Status::OK) << result.message;
  EXPECT_EQ(result.payload, echoed.SerializeAsString());
  const auto to_jp = sent();
  ASSERT_TRUE(to_jp);
  EXPECT_TRUE(to_jp->blocking);
  EXPECT_EQ(to_jp->payload, echo.SerializeAsString());
}

}  // namespace
}  // namespace urs::bridge::core
