#include "urs/camus_server/context_store.hpp"

#include <gtest/gtest.h>

#include "fakes.hpp"

namespace urs::camus_server::test {
namespace {

namespace gp = google::protobuf;

camus::ContextSetRequest set_request(const std::string& key, double number, uint32_t ttl_ms = 0,
                                     const std::string& source = "") {
  camus::ContextSetRequest request;
  request.set_key(key);
  request.mutable_value()->set_number_value(number);
  request.set_ttl_ms(ttl_ms);
  request.set_source(source);
  return request;
}

class ContextTest : public ::testing::Test {
 protected:
  RecordingSink sink;
  ManualClock clock;
  ManualScheduler timers;
};

TEST_F(ContextTest, SetThenGetWithSourceTimeAndVersion) {
  ContextStore store("", sink, clock, timers);
  auto set = store.set(set_request("robot1/battery", 0.8), "sam@robot1");
  ASSERT_TRUE(set.ok()) << set.message();
  EXPECT_EQ(set->version(), 1u);
  EXPECT_EQ(set->source(), "sam@robot1");
  EXPECT_EQ(set->updated_unix_ns(), clock.now_unix_ns());
  EXPECT_EQ(set->expires_unix_ns(), 0);

  auto got = store.get("robot1/battery");
  ASSERT_TRUE(got.ok());
  EXPECT_DOUBLE_EQ(got->value().number_value(), 0.8);
  EXPECT_EQ(got->version(), 1u);

  auto again = store.set(set_request("robot1/battery", 0.7, 0, "planner"), "sam@robot1");
  EXPECT_EQ(again->version(), 2u);
  EXPECT_EQ(again->source(), "sam@robot1");  // who set it, as authenticated
  EXPECT_EQ(again->origin(), "planner");     // what the setter declared

  auto events = sink.events();
  ASSERT_EQ(events.size(), 2u);
  EXPECT_EQ(events[0].topic, "context/robot1/battery");
  EXPECT_EQ(events[0].type, "urs.camus.ContextEntry");
  EXPECT_EQ(events[1].as<camus::ContextEntry>().version(), 2u);
}

TEST_F(ContextTest, UnknownKeyAndBadInputAreNamed) {
  ContextStore store("", sink, clock, timers);
  EXPECT_EQ(store.get("nope").status(), planet::NOT_FOUND);
  EXPECT_EQ(store.get("nope").message(), "no context entry 'nope'");
  EXPECT_EQ(store.remove("nope", "x").message(), "no context entry 'nope'");
  EXPECT_EQ(store.set(set_request("a/*", 1), "x").message(),
            "context key 'a/*' is not valid: level 2 ('*') holds a wildcard");
  camus::ContextSetRequest no_value;
  no_value.set_key("k");
  EXPECT_EQ(store.set(no_value, "x").message(), "context entry 'k': value is missing (use Delete to remove an entry)");
  EXPECT_EQ(store.list("a/#/b").message(), "invalid pattern 'a/#/b': '#' is only allowed as the last level");
  // A 10 MB key is quoted by its first 64 bytes and its size, not echoed back.
  const std::string huge(10'000'000, 'k');
  EXPECT_EQ(store.get(huge).message(), "no context entry '" + huge.substr(0, 64) + "...' (10000000 bytes)");
  EXPECT_TRUE(sink.events().empty());
}

TEST_F(ContextTest, TtlHidesAtOnceAndPurgePublishesNull) {
  ContextStore store("", sink, clock, timers);
  ASSERT_TRUE(store.set(set_request("door/open", 1, 1000), "sam").ok());
  EXPECT_EQ(store.get("door/open")->expires_unix_ns(), clock.now_unix_ns() + 1'000'000'000);
  clock.advance(std::chrono::milliseconds(999));
  EXPECT_TRUE(store.get("door/open").ok());
  clock.advance(std::chrono::milliseconds(1));
  EXPECT_EQ(store.get("door/open").status(), planet::NOT_FOUND);  // invisible before the purge
  EXPECT_TRUE(store.list("")->empty());
  EXPECT_EQ(sink.events().size(), 1u);
  timers.advance(std::chrono::milliseconds(1000));  // the purge timer fires
  auto events = sink.events();
  ASSERT_EQ(events.size(), 2u);
  auto expired = events[1].as<camus::ContextEntry>();
  EXPECT_EQ(expired.key(), "door/open");
  EXPECT_EQ(expired.value().kind_case(), gp::Value::kNullValue);
  EXPECT_EQ(expired.version(), 2u);
  EXPECT_EQ(expired.source(), "camus-server");
}

TEST_F(ContextTest, RearmedTtlPurgesOnlyWhenDue) {
  ContextStore store("", sink, clock, timers);
  ASSERT_TRUE(store.set(set_request("a", 1, 500), "s").ok());
  ASSERT_TRUE(store.set(set_request("b", 1, 100), "s").ok());
  clock.advance(std::chrono::milliseconds(100));
  timers.advance(std::chrono::milliseconds(100));
  EXPECT_EQ(sink.events().size(), 3u);  // b expired
  EXPECT_TRUE(store.get("a").ok());
  clock.advance(std::chrono::milliseconds(400));
  timers.advance(std::chrono::milliseconds(400));
  EXPECT_EQ(sink.events().size(), 4u);
  EXPECT_EQ(store.get("a").status(), planet::NOT_FOUND);
  EXPECT_EQ(timers.pending(), 0u);
}

TEST_F(ContextTest, DeleteKeepsVersionsIncreasing) {
  ContextStore store("", sink, clock, timers);
  ASSERT_TRUE(store.set(set_request("k", 1), "s").ok());
  ASSERT_TRUE(store.remove("k", "cleaner").ok());
  auto deleted = sink.events().back().as<camus::ContextEntry>();
  EXPECT_EQ(deleted.version(), 2u);
  EXPECT_EQ(deleted.value().kind_case(), gp::Value::kNullValue);
  EXPECT_EQ(deleted.source(), "cleaner");
  EXPECT_EQ(store.get("k").status(), planet::NOT_FOUND);
  EXPECT_EQ(store.set(set_request("k", 2), "s")->version(), 3u);
}

TEST_F(ContextTest, ListFiltersWithTopicPatterns) {
  ContextStore store("", sink, clock, timers);
  store.set(set_request("robot1/pose", 1), "s");
  store.set(set_request("robot1/battery", 1), "s");
  store.set(set_request("robot2/pose", 1), "s");
  EXPECT_EQ(store.list("")->size(), 3u);
  auto robot1 = store.list("robot1/#");
  ASSERT_EQ(robot1->size(), 2u);
  EXPECT_EQ(robot1.value()[0].key(), "robot1/battery");
  EXPECT_EQ(store.list("*/pose")->size(), 2u);
  EXPECT_EQ(store.list("robot1/*")->size(), 2u);  // glob
  EXPECT_EQ(store.list("robot?/pose")->size(), 2u);
  EXPECT_EQ(store.list("#")->size(), 3u);  // topic pattern
}

TEST_F(ContextTest, EntriesAndVersionsSurviveReopen) {
  TempDir dir;
  {
    ContextStore store(dir.file("context.db"), sink, clock, timers);
    store.set(set_request("robot1/pose", 1.5), "sam");
    store.set(set_request("robot1/pose", 2.5), "sam");
    store.set(set_request("gone", 1), "sam");
    store.remove("gone", "sam");
    store.set(set_request("short", 1, 1000), "sam");
  }
  clock.advance(std::chrono::seconds(2));  // "short" expires while the server is down
  RecordingSink after;
  ContextStore store(dir.file("context.db"), after, clock, timers);
  auto pose = store.get("robot1/pose");
  ASSERT_TRUE(pose.ok());
  EXPECT_DOUBLE_EQ(pose->value().number_value(), 2.5);
  EXPECT_EQ(pose->version(), 2u);
  EXPECT_EQ(store.get("gone").status(), planet::NOT_FOUND);
  EXPECT_EQ(store.set(set_request("gone", 3), "sam")->version(), 3u);
  EXPECT_EQ(store.get("short").status(), planet::NOT_FOUND);
  auto events = after.events();
  ASSERT_GE(events.size(), 1u);
  EXPECT_EQ(events[0].topic, "context/short");  // purged at open, published
  EXPECT_EQ(events[0].as<camus::ContextEntry>().value().kind_case(), gp::Value::kNullValue);
}

TEST_F(ContextTest, AgentServesTheContextInterface) {
  ContextStore store("", sink, clock, timers);
  ContextAgent agent(store);
  const auto& iface = agent.interface();
  EXPECT_EQ(iface.full_name(), "urs.camus.Context");
  agent::CallContext ctx;
  ctx.caller.name = "cli@host";
  camus::ContextEntry reply;
  auto outcome = agent.invoke(*iface.FindMethodByName("Set"), set_request("k", 4), reply, ctx);
  ASSERT_EQ(outcome.status, call::Status::OK) << outcome.message;
  EXPECT_EQ(reply.source(), "cli@host");
  camus::ContextGetRequest get;
  get.set_key("missing");
  outcome = agent.invoke(*iface.FindMethodByName("Get"), get, reply, ctx);
  EXPECT_EQ(outcome.status, call::Status::NOT_FOUND);
  EXPECT_EQ(outcome.message, "no context entry 'missing'");
  camus::ContextListReply list;
  outcome = agent.invoke(*iface.FindMethodByName("List"), camus::ContextListRequest(), list, ctx);
  ASSERT_EQ(outcome.status, call::Status::OK);
  EXPECT_EQ(list.entries_size(), 1);
}

}  // namespace
}  // namespace urs::camus_server::test
