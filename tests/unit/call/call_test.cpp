// The neutral call model: status names and numbers, Reply's helpers, the Responder contract.

#include "urs/call/call.hpp"

#include <gtest/gtest.h>

#include <optional>
#include <set>
#include <stdexcept>
#include <thread>
#include <vector>

namespace urs::call {
namespace {

TEST(CallStatus, EveryNumberHasItsOwnName) {
  std::set<std::string_view> names;
  for (std::int32_t number = 0; number <= kLastStatus; ++number) {
    const auto status = status_from_number(number);
    ASSERT_TRUE(status) << number;
    EXPECT_EQ(status_number(*status), number);
    EXPECT_NE(status_name(*status), "UNKNOWN_STATUS") << number;
    names.insert(status_name(*status));
  }
  EXPECT_EQ(names.size(), static_cast<std::size_t>(kLastStatus + 1));
  EXPECT_EQ(status_name(Status::DEADLINE_EXCEEDED), "DEADLINE_EXCEEDED");
}

TEST(CallStatus, NumbersOutsideTheSetAreRefused) {
  EXPECT_FALSE(status_from_number(-1));
  EXPECT_FALSE(status_from_number(kLastStatus + 1));
  EXPECT_FALSE(status_from_number(std::int64_t{1} << 40));
  EXPECT_EQ(status_name(static_cast<Status>(999)), "UNKNOWN_STATUS");
}

TEST(CallReply, Helpers) {
  EXPECT_TRUE(Reply::success("x").ok());
  const auto error = Reply::error(Status::NOT_FOUND, "no key 'a'");
  EXPECT_FALSE(error.ok());
  EXPECT_EQ(error.message, "no key 'a'");
  const auto exception = Reply::user_exception("urs.X", "bytes", "boom");
  EXPECT_EQ(exception.status, Status::USER_EXCEPTION);
  EXPECT_EQ(exception.exception_type, "urs.X");
  EXPECT_EQ(exception.payload, "bytes");
}

TEST(CallRequest, HasNoDeadlineUntilOneIsSet) {
  Request request;
  EXPECT_FALSE(request.has_deadline());
  EXPECT_FALSE(request.caller.known());
  request.deadline = Request::Clock::now();
  EXPECT_TRUE(request.has_deadline());
}

TEST(CallResponder, AnswersOnceFromAnyThread) {
  std::vector<Reply> replies;
  Responder responder = Responder::from_callback([&](Reply r) { replies.push_back(r); });
  EXPECT_TRUE(responder.pending());
  std::thread other([&] { responder.reply(Reply::success("p")); });
  other.join();
  responder.reply(Reply::success("again"));
  EXPECT_FALSE(responder.pending());
  ASSERT_EQ(replies.size(), 1u);
  EXPECT_EQ(replies[0].payload, "p");
}

TEST(CallResponder, DestroyedUnansweredAnswersInternal) {
  std::optional<Reply> reply;
  {
    Responder responder = Responder::from_callback([&](Reply r) { reply = r; });
    Responder moved = std::move(responder);  // the moved-from one must not answer
    EXPECT_FALSE(responder.pending());
    EXPECT_TRUE(moved.pending());
  }
  ASSERT_TRUE(reply);
  EXPECT_EQ(reply->status, Status::INTERNAL);
  EXPECT_EQ(reply->message, "provider dropped the request");
}

TEST(CallResponder, AssignedOverUnansweredAnswersInternal) {
  std::vector<Status> answers;
  Responder a = Responder::from_callback([&](Reply r) { answers.push_back(r.status); });
  Responder b = Responder::from_callback([&](Reply r) { answers.push_back(r.status); });
  a = std::move(b);
  ASSERT_EQ(answers.size(), 1u);
  EXPECT_EQ(answers[0], Status::INTERNAL);
  a.reply(Reply::success({}));
  ASSERT_EQ(answers.size(), 2u);
  EXPECT_EQ(answers[1], Status::OK);
}

TEST(CallResponder, ACallbackThatThrowsWhenDroppedIsContained) {
  EXPECT_NO_THROW(
      { Responder responder = Responder::from_callback([](Reply) { throw std::runtime_error("link closed"); }); });
}

TEST(CallResponder, DefaultConstructedAnswersNowhere) {
  Responder responder;
  EXPECT_FALSE(responder.pending());
  responder.reply(Reply::success({}));
  EXPECT_FALSE(Responder::from_callback({}).pending());
}

}  // namespace
}  // namespace urs::call
