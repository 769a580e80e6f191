#include "urs/camus_server/task_spec.hpp"

#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

namespace urs::camus_server {
namespace {

std::string read(const std::string& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

TEST(TaskSpec, SquarePathParses) {
  auto spec = parse_task(read(URS_CAMUS_TASKS_DIR "/square-path.yaml"), "");
  ASSERT_TRUE(spec.ok()) << spec.message();
  EXPECT_EQ(spec->name, "square-path");
  EXPECT_EQ(spec->repeat, 1u);
  ASSERT_EQ(spec->steps.size(), 11u);
  const auto& speed = std::get<CallStep>(spec->steps[0].action);
  EXPECT_EQ(speed.service, "robot1.navigation");
  EXPECT_EQ(speed.operation, "setSpeed");
  EXPECT_EQ(speed.args_json, "{\"speed\":500}");
  EXPECT_EQ(speed.deadline_ms, 5000u);
  const auto& first_move = std::get<CallStep>(spec->steps[1].action);
  EXPECT_EQ(first_move.args_json, "{\"x\":1.5,\"y\":1}");
  const auto& wait = std::get<WaitEventStep>(spec->steps[2].action);
  EXPECT_EQ(wait.pattern.text(), "robot1.navigation/arrived");
  EXPECT_EQ(wait.timeout_ms, 60000u);
  EXPECT_EQ(spec->steps[2].summary(), "wait_event robot1.navigation/arrived");
  EXPECT_EQ(spec->steps[1].summary(), "call robot1.navigation.moveTo");
}

TEST(TaskSpec, AllStepKindsAndOptions) {
  auto spec = parse_task(R"(
name: patrol
description: go and come back
repeat: 3
trigger: {event: "kr/+/doorbell/#"}
steps:
  - call: {service: s, operation: o}
  - wait_event: {pattern: "a/*", match: {x: 1.5, who: "7", ok: true}}
  - wait_context: {key: door/open, equals: yes}
  - wait_context: {key: door/open, exists: false, timeout_ms: 10}
  - sleep: {ms: 250}
  - publish: {topic: kr/door, type: URS.Failure, payload: {reason: open, code: 2}}
)",
                         "");
  ASSERT_TRUE(spec.ok()) << spec.message();
  EXPECT_EQ(spec->repeat, 3u);
  EXPECT_EQ(spec->trigger, "kr/+/doorbell/#");
  EXPECT_TRUE(spec->trigger_pattern.matches("kr/+/doorbell/front"));
  EXPECT_EQ(std::get<CallStep>(spec->steps[0].action).args_json, "{}");
  const auto& wait = std::get<WaitEventStep>(spec->steps[1].action);
  ASSERT_EQ(wait.match.size(), 3u);
  EXPECT_EQ(wait.match[0].first, "x");
  EXPECT_DOUBLE_EQ(wait.match[0].second.number_value(), 1.5);
  EXPECT_EQ(wait.match[1].second.string_value(), "7");  // quoted: stays text
  EXPECT_TRUE(wait.match[2].second.bool_value());
  const auto& equals = std::get<WaitContextStep>(spec->steps[2].action);
  EXPECT_TRUE(equals.has_equals);
  EXPECT_EQ(equals.equals.string_value(), "yes");  // YAML 1.2: "yes" is text
  const auto& absent = std::get<WaitContextStep>(spec->steps[3].action);
  EXPECT_FALSE(absent.has_equals);
  EXPECT_FALSE(absent.exists);
  EXPECT_EQ(std::get<SleepStep>(spec->steps[4].action).ms, 250u);
  EXPECT_EQ(spec->steps[4].line, 11);
  const auto& publish = std::get<PublishStep>(spec->steps[5].action);
  EXPECT_EQ(publish.topic, "kr/door");
  EXPECT_EQ(publish.type, "URS.Failure");
  EXPECT_EQ(publish.payload_json, R"({"reason":"open","code":2})");
  EXPECT_EQ(spec->steps[5].summary(), "publish kr/door (URS.Failure)");
}

TEST(TaskSpec, NameComesFromTheCallerWhenAbsent) {
  auto spec = parse_task("steps: [{sleep: {ms: 1}}]", "from-file");
  ASSERT_TRUE(spec.ok()) << spec.message();
  EXPECT_EQ(spec->name, "from-file");
}

struct BadCase {
  const char* yaml;
  const char* message;
};

class TaskSpecErrors : public ::testing::TestWithParam<BadCase> {};

TEST_P(TaskSpecErrors, AreReportedWithPathAndLine) {
  auto spec = parse_task(GetParam().yaml, "t");
  ASSERT_FALSE(spec.ok());
  EXPECT_EQ(spec.status(), planet::BAD_ARGUMENTS);
  EXPECT_EQ(spec.message(), GetParam().message);
}

INSTANTIATE_TEST_SUITE_P(
    Table, TaskSpecErrors,
    ::testing::Values(
        BadCase{"steps: [", "task 't': YAML does not parse: line 1, column 1: end of sequence flow not found"},
        BadCase{"- a\n- b", "task 't': expected a map with 'steps', got a list"},
        BadCase{"name: t", "task 't': task (line 1): missing 'steps'"},
        BadCase{"steps: []", "task 't': steps (line 1): expected a non-empty list of steps, got a list"},
        BadCase{"name: bad name\nsteps: [{sleep: {ms: 1}}]",
                "task 't': name (line 1): task name 'bad name' is not valid: character ' ' is not allowed (use "
                "letters, digits and . _ -)"},
        BadCase{"steps:\n  - call: {service: s}\n", "task 't': steps[0].call (line 2): missing 'operation'"},
        BadCase{"steps:\n  - call: {service: s, operation: o, servce: x}\n",
                "task 't': steps[0].call.servce (line 2): unknown key 'servce' (expected service, operation, args, "
                "deadline_ms)"},
        BadCase{"steps:\n  - call: {service: s, operation: o, deadline_ms: soon}\n",
                "task 't': steps[0].call.deadline_ms (line 2): 'soon' is not a number of milliseconds (1..4294967295)"},
        BadCase{"steps:\n  - call: {service: s, operation: o, args: [1, 2]}\n",
                "task 't': steps[0].call.args (line 2): expected a map of request fields, got a list"},
        BadCase{"steps:\n  - sleep: {ms: 1}\n  - fly: {to: moon}\n",
                "task 't': steps[1] (line 3): unknown step 'fly' (expected call, wait_event, wait_context, sleep or "
                "publish)"},
        BadCase{"steps:\n  - publish: {topic: \"a/*\", payload: [1]}\n",
                "task 't': steps[0].publish.topic (line 2): topic 'a/*' is not valid: level 2 ('*') holds a wildcard; "
                "steps[0].publish (line 2): missing 'type'; steps[0].publish.payload (line 2): expected a map of the "
                "event's fields, got a list"},
        BadCase{"steps:\n  - {sleep: {ms: 1}, call: {service: s, operation: o}}\n",
                "task 't': steps[0] (line 2): a step is a map with exactly one of call, wait_event, wait_context, "
                "sleep, publish"},
        BadCase{"steps:\n  - wait_event: {pattern: \"a/#/b\"}\n",
                "task 't': steps[0].wait_event.pattern (line 2): invalid pattern 'a/#/b': '#' is only allowed as the "
                "last level"},
        BadCase{"steps:\n  - wait_context: {key: k}\n",
                "task 't': steps[0].wait_context (line 2): missing 'equals' or 'exists'"},
        BadCase{"steps:\n  - wait_context: {key: k, equals: 1, exists: true}\n",
                "task 't': steps[0].wait_context (line 2): give either 'equals' or 'exists', not both"},
        BadCase{"steps:\n  - wait_context: {key: k, exists: maybe}\n",
                "task 't': steps[0].wait_context.exists (line 2): 'maybe' is not true or false"},
        BadCase{"steps:\n  - sleep: {}\n", "task 't': steps[0].sleep (line 2): missing 'ms'"},
        BadCase{"steps:\n  - sleep: 5\n", "task 't': steps[0].sleep (line 2): expected a map, got '5'"},
        BadCase{"repeat: 0\nsteps: [{sleep: {ms: 1}}]",
                "task 't': task.repeat (line 1): '0' is not a repeat count (1..1000000)"},
        BadCase{"trigger: {event: \"a/#/b\"}\nsteps: [{sleep: {ms: 1}}]",
                "task 't': trigger.event (line 1): invalid pattern 'a/#/b': '#' is only allowed as the last level"},
        // Every problem is reported, not just the first.
        BadCase{"steps:\n  - call: {service: s}\n  - sleep: {ms: -1}\nextra: 1\n",
                "task 't': task.extra (line 4): unknown key 'extra' (expected name, description, repeat, trigger, "
                "steps); steps[0].call (line 2): missing 'operation'; steps[1].sleep.ms (line 3): '-1' is not a "
                "number of milliseconds (0..4294967295)"}));

TEST(TaskSpec, YamlToJsonFollowsTheCoreSchema) {
  EXPECT_EQ(
      yaml_text_to_json("{a: 1, b: -2.5, c: true, d: null, e: hello, f: '12', g: [1, x], h: 1e3, i: +7}"),
      "{\"a\":1,\"b\":-2.5,\"c\":true,\"d\":null,\"e\":\"hello\",\"f\":\"12\",\"g\":[1,\"x\"],\"h\":1000,\"i\":7}");
  EXPECT_EQ(yaml_text_to_json("{q: \"say \\\"hi\\\"\\n\"}"), "{\"q\":\"say \\\"hi\\\"\\n\"}");
}

}  // namespace
}  // namespace urs::camus_server
