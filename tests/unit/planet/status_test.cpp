// status_name() and the Responder contract (in-process, no sockets).

#include "urs/planet/status.hpp"

#include <gtest/gtest.h>

#include <optional>
#include <set>
#include <thread>

#include "urs/planet/client.hpp"
#include "urs/planet/reply.hpp"

namespace urs::planet {
namespace {

TEST(PlanetStatusName, NamesEveryStatusAsInTheProto) {
  const auto* descriptor = Status_descriptor();
  std::set<std::string_view> names;
  for (int i = 0; i < descriptor->value_count(); ++i) {
    const auto* value = descriptor->value(i);
    EXPECT_EQ(status_name(static_cast<Status>(value->number())), value->name());
    names.insert(status_name(static_cast<Status>(value->number())));
  }
  EXPECT_EQ(names.size(), static_cast<size_t>(descriptor->value_count()));
  EXPECT_EQ(status_name(static_cast<Status>(999)), "UNKNOWN_STATUS");
}

TEST(PlanetCallResult, Helpers) {
  EXPECT_TRUE(CallResult::success("x").ok());
  const auto error = CallResult::error(Status::NOT_FOUND, "no key 'a'");
  EXPECT_FALSE(error.ok());
  EXPECT_EQ(error.message, "no key 'a'");
  const auto exception = CallResult::user_exception("urs.X", "bytes", "boom");
  EXPECT_EQ(exception.status, Status::USER_EXCEPTION);
  EXPECT_EQ(exception.exception_type, "urs.X");
}

TEST(PlanetResponder, RepliesOnceFromAnyThread) {
  std::vector<CallResult> results;
  Responder responder = Responder::from_callback([&](CallResult r) { results.push_back(r); });
  EXPECT_TRUE(responder.pending());
  std::thread other([&] { responder.reply(CallResult::success("p")); });
  other.join();
  responder.reply(CallResult::success("again"));
  EXPECT_FALSE(responder.pending());
  ASSERT_EQ(results.size(), 1u);
  EXPECT_EQ(results[0].payload, "p");
}

TEST(PlanetResponder, DroppedUnansweredRepliesInternal) {
  std::optional<CallResult> result;
  {
    Responder responder = Responder::from_callback([&](CallResult r) { result = r; });
    Responder moved = std::move(responder);  // the moved-from one must not answer
    EXPECT_FALSE(responder.pending());
    EXPECT_TRUE(moved.pending());
  }
  ASSERT_TRUE(result);
  EXPECT_EQ(result->status, Status::INTERNAL);
  EXPECT_EQ(result->message, "provider dropped the request");
}

TEST(PlanetResponder, MoveAssignOverAPendingOneAnswersIt) {
  int answered = 0;
  Responder a = Responder::from_callback([&](CallResult r) {
    EXPECT_EQ(r.status, Status::INTERNAL);
    ++answered;
  });
  Responder b = Responder::from_callback([&](CallResult) { ++answered; });
  a = std::move(b);
  EXPECT_EQ(answered, 1);
  a.reply(CallResult::success({}));
  EXPECT_EQ(answered, 2);
}

TEST(PlanetResponder, DefaultConstructedIsInert) {
  Responder responder;
  EXPECT_FALSE(responder.pending());
  responder.reply(CallResult::success({}));
}

TEST(PlanetCallResult, TravelsInAReplyAndBack) {
  Frame frame = reply_frame(42, CallResult::user_exception("urs.Err", "bytes", "it failed"));
  ASSERT_TRUE(frame.has_reply());
  EXPECT_EQ(frame.reply().call_id(), 42u);
  const CallResult back = result_of(std::move(*frame.mutable_reply()));
  EXPECT_EQ(back.status, Status::USER_EXCEPTION);
  EXPECT_EQ(back.exception_type, "urs.Err");
  EXPECT_EQ(back.payload, "bytes");
  EXPECT_EQ(back.message, "it failed");
}

}  // namespace
}  // namespace urs::planet
