// CamusForwardingAgent on an AgentHost, over an in-memory route: the calls it takes through
// forward() (bytes passed on unparsed both ways, a raised exception checked, the deadline left),
// and those it leaves to the host's worker path when the route cannot start them without blocking.

#include <gtest/gtest.h>

#include <future>
#include <thread>
#include <mutex>
#include <optional>

#include "Diagnostic.pb.h"
#include "urs/agent/agent.hpp"
#include "urs/bridge/camus_forwarding_agent.hpp"

namespace urs::bridge {
namespace {

using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;

// What the route was handed; a test answers the calls it started through `done`.
struct Sent {
  std::string operation;
  std::string payload;
  std::chrono::milliseconds deadline{0};
  call::Identity caller;
  CamusForwardingAgent::Route::Done done;
  bool blocking = false;  // through Route::call / Route::oneway
};

const std::string kGarbage = std::string("\xff\xff\xff", 3) + " not a message";

class Forwarding : public ::testing::Test {
 protected:
  Forwarding() : host_(1, events_) {
    CamusForwardingAgent::Route route{
        [this](const std::string& operation, std::string payload, std::chrono::milliseconds deadline,
               const call::Identity& caller) {
          record({operation, std::move(payload), deadline, caller, nullptr, true});
          return blocking_reply_;
        },
        [this](const std::string& operation, std::string payload, const call::Identity& caller) {
          record({operation, std::move(payload), 0ms, caller, nullptr, true});
          return true;
        },
        [this](const std::string& operation, std::string&& payload, std::chrono::milliseconds deadline,
               const call::Identity& caller, CamusForwardingAgent::Route::Done done) {
          if (!starts_) return false;
          record({operation, std::move(payload), deadline, caller, std::move(done), false});
          return true;
        },
        [this](const std::string& operation, std::string&& payload,
               const call::Identity& caller) -> std::optional<bool> {
          if (!starts_) return std::nullopt;
          record({operation, std::move(payload), 0ms, caller, nullptr, false});
          return true;
        },
        "space jp"};
    const auto* interface = URS::Diagnostic_echo_Request::descriptor()->file()->FindServiceByName("Diagnostic");
    host_.add({"jp/diag", std::make_shared<CamusForwardingAgent>(route, "diag", *interface), {}, 0});
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
    request.caller = {"", "alice", "client"};
    request.oneway = oneway;
    auto promise = std::make_shared<std::promise<call::Reply>>();
    answered_ = promise->get_future();
    host_.dispatch(std::move(request),
                   oneway ? call::Responder()
                          : call::Responder::from_callback([promise](call::Reply reply) { promise->set_value(reply); }));
  }
  bool answered() { return answered_.wait_for(0s) == std::future_status::ready; }
  call::Reply answer() {
    if (answered_.wait_for(5s) != std::future_status::ready) return call::Reply::error(call::Status::INTERNAL, "no answer");
    return answered_.get();
  }
  std::optional<Sent> sent() {
    std::lock_guard lock(mutex_);
    return sent_;
  }
  // The completion of the call the route started last.
  void reply(call::Reply result) {
    auto done = sent()->done;
    done(std::move(result));
  }

  void record(Sent sent) {
    std::lock_guard lock(mutex_);
    sent_ = std::move(sent);
  }

  agent::DiscardingEventSink events_;
  agent::AgentHost host_;
  bool starts_ = true;  // whether the route starts calls without blocking
  call::Reply blocking_reply_ = call::Reply::error(call::Status::INTERNAL, "not set");
  std::mutex mutex_;
  std::optional<Sent> sent_;
  std::future<call::Reply> answered_;
};

// The request's bytes reach the route as they came, even bytes that are no request of the
// operation (the far end refuses those), and the reply's come back as they came.
TEST_F(Forwarding, ACallsBytesPassThroughUnparsedBothWays) {
  dispatch("echo", kGarbage);
  const auto to_jp = sent();
  ASSERT_TRUE(to_jp);
  EXPECT_FALSE(to_jp->blocking);
  EXPECT_EQ(to_jp->operation, "echo");
  EXPECT_EQ(to_jp->payload, kGarbage);
  EXPECT_GT(to_jp->deadline, 1500ms);
  EXPECT_LE(to_jp->deadline, 2000ms);
  EXPECT_EQ(to_jp->caller.name, "alice");
  EXPECT_FALSE(answered()) << "answered before the route's reply";

  const std::string not_a_reply("\xfe\xfe back", 7);
  reply(call::Reply::success(not_a_reply));
  const auto result = answer();
  ASSERT_EQ(result.status, call::Status::OK) << result.message;
  EXPECT_EQ(result.payload, not_a_reply);
}

// The route answers from its own thread, as a DDS listener or a Planet I/O thread would.
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
}

// A call the route cannot start without blocking is left as it came: the host parses it and runs
// invoke() on a worker, which takes the blocking route.
TEST_F(Forwarding, ACallTheRouteCannotStartRunsOnAWorkerAsBefore) {
  starts_ = false;
  dispatch("echo", kGarbage);
  auto result = answer();
  EXPECT_EQ(result.status, call::Status::BAD_ARGUMENTS);
  EXPECT_EQ(result.message, "payload of jp/diag.echo is not a valid URS.Diagnostic_echo_Request");
  EXPECT_FALSE(sent());

  URS::Diagnostic_echo_Request echo;
  echo.set_text("hello");
  URS::Diagnostic_echo_Reply echoed;
  echoed.set_result("hello");
  blocking_reply_ = call::Reply::success(echoed.SerializeAsString());
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
}  // namespace urs::bridge
