// RateLimiter: a burst per window and key, then a count of what was suppressed.

#include "urs/util/rate_limit.hpp"

#include <gtest/gtest.h>

#include <thread>

namespace urs::util {
namespace {

TEST(RateLimiter, AllowsABurstPerKeyThenCountsWhatItSuppressed) {
  RateLimiter limiter(2, std::chrono::milliseconds(200));
  uint64_t suppressed = 99;
  EXPECT_TRUE(limiter.allow("10.0.0.1", suppressed));
  EXPECT_EQ(suppressed, 0u);
  EXPECT_TRUE(limiter.allow("10.0.0.1", suppressed));
  for (int i = 0; i < 5; ++i) EXPECT_FALSE(limiter.allow("10.0.0.1", suppressed));
  EXPECT_TRUE(limiter.allow("10.0.0.2", suppressed)) << "another address has its own budget";
  EXPECT_EQ(suppressed, 0u);
  std::this_thread::sleep_for(std::chrono::milliseconds(250));
  EXPECT_TRUE(limiter.allow("10.0.0.1", suppressed));
  EXPECT_EQ(suppressed, 5u);
  EXPECT_TRUE(limiter.allow("10.0.0.1", suppressed));
  EXPECT_EQ(suppressed, 0u);
}

TEST(RateLimiter, AFloodOfKeysSharesOneEntry) {
  RateLimiter limiter(1, std::chrono::seconds(60), 4);
  uint64_t suppressed = 0;
  for (int i = 0; i < 4; ++i) EXPECT_TRUE(limiter.allow("k" + std::to_string(i), suppressed));
  EXPECT_TRUE(limiter.allow("k4", suppressed));   // the shared entry's first
  EXPECT_FALSE(limiter.allow("k5", suppressed));  // shares it
  EXPECT_EQ(suppressed_note(0), "");
  EXPECT_EQ(suppressed_note(3), " (3 similar messages suppressed)");
}

}  // namespace
}  // namespace urs::util
