// urs::util trace context: W3C traceparent values read and written, new traces and children, the
// thread's current trace.

#include "urs/util/trace.hpp"

#include <gtest/gtest.h>

#include <thread>

namespace urs::util {
namespace {

constexpr const char* kExample = "00-4bf92f3577b34da6a3ce929d0e0e4736-00f067aa0ba902b7-01";

TEST(TraceContext, ReadsAndWritesTheRecommendationsExample) {
  auto trace = TraceContext::parse(kExample);
  ASSERT_TRUE(trace);
  EXPECT_EQ(trace->trace_id_hex(), "4bf92f3577b34da6a3ce929d0e0e4736");
  EXPECT_EQ(trace->flags, 1);
  EXPECT_EQ(trace->traceparent(), kExample);
}

TEST(TraceContext, RefusesWhatIsNotAValidTraceparent) {
  const char* invalid[] = {
      "",
      "00-4bf92f3577b34da6a3ce929d0e0e4736-00f067aa0ba902b7-0",    // short
      "00-4bf92f3577b34da6a3ce929d0e0e4736-00f067aa0ba902b7-01-",  // version 00 with more
      "00-4BF92F3577B34DA6A3CE929D0E0E4736-00f067aa0ba902b7-01",   // upper case
      "00-00000000000000000000000000000000-00f067aa0ba902b7-01",   // all-zero trace id
      "00-4bf92f3577b34da6a3ce929d0e0e4736-0000000000000000-01",   // all-zero parent id
      "ff-4bf92f3577b34da6a3ce929d0e0e4736-00f067aa0ba902b7-01",   // version ff
      "00_4bf92f3577b34da6a3ce929d0e0e4736-00f067aa0ba902b7-01",   // separator
      "00-4bf92f3577b34da6a3ce929d0e0e47zz-00f067aa0ba902b7-01",   // not hex
      "01-4bf92f3577b34da6a3ce929d0e0e4736-00f067aa0ba902b7-01x",  // later version, no '-'
  };
  for (const char* text : invalid) EXPECT_FALSE(TraceContext::parse(text)) << text;
  EXPECT_FALSE(TraceContext::parse(std::string(kExample) + std::string(300, '-')));  // over kMaxTraceparentBytes
}

TEST(TraceContext, ReadsALaterVersionsFirstFields) {
  auto trace = TraceContext::parse("01-4bf92f3577b34da6a3ce929d0e0e4736-00f067aa0ba902b7-01-future");
  ASSERT_TRUE(trace);
  EXPECT_EQ(trace->traceparent(), kExample);  // written as version 00
}

TEST(TraceContext, StartMakesValidSampledTracesThatDiffer) {
  auto a = TraceContext::start();
  auto b = TraceContext::start();
  EXPECT_NE(a.trace_id, b.trace_id);
  EXPECT_EQ(a.flags, 1);
  EXPECT_EQ(TraceContext::parse(a.traceparent()), a);
}

TEST(TraceContext, ChildKeepsTheTraceUnderANewParent) {
  auto parent = *TraceContext::parse(kExample);
  auto child = parent.child();
  EXPECT_EQ(child.trace_id, parent.trace_id);
  EXPECT_EQ(child.flags, parent.flags);
  EXPECT_NE(child.parent_id, parent.parent_id);
}

TEST(TraceScope, SetsTheThreadsCurrentTraceAndRestoresTheOneBefore) {
  EXPECT_EQ(current_trace(), nullptr);
  auto outer = *TraceContext::parse(kExample);
  {
    TraceScope scope(outer);
    ASSERT_NE(current_trace(), nullptr);
    EXPECT_EQ(*current_trace(), outer);
    EXPECT_EQ(outgoing_trace().trace_id, outer.trace_id);
    {
      auto inner = TraceContext::start();
      TraceScope nested(inner);
      EXPECT_EQ(*current_trace(), inner);
      TraceScope none(std::nullopt);  // leaves it as it is
      EXPECT_EQ(*current_trace(), inner);
    }
    EXPECT_EQ(*current_trace(), outer);
    std::thread([] { EXPECT_EQ(current_trace(), nullptr); }).join();  // per thread
  }
  EXPECT_EQ(current_trace(), nullptr);
  EXPECT_NE(outgoing_trace().trace_id, outer.trace_id);  // outside a scope: a new trace
}

}  // namespace
}  // namespace urs::util
