#pragma once
// Declarative tasks: the YAML form, parsed and validated once into an immutable TaskSpec.
//
//   name: square-path             # [A-Za-z0-9_.-]+; optional when the name is given elsewhere
//   description: ...              # optional
//   repeat: 1                     # optional, 1..1000000: run the steps this many times
//   trigger: {event: "kr/#"}      # optional: start a run when a matching event arrives
//   steps:                        # one or more; each step is a map with exactly one action:
//     - call: {service: S, operation: O, args: {...}, deadline_ms: N}
//     - wait_event: {pattern: P, timeout_ms: N, match: {field: value}}
//     - wait_context: {key: K, equals: V | exists: true|false, timeout_ms: N}
//     - sleep: {ms: N}
//     - publish: {topic: T, type: TYPE, payload: {...}}
//
// `args` is any YAML map; it is converted to JSON and then, through Protobuf's JSON mapping, to
// the operation's request message. A timeout of 0 (or none) waits until the run is cancelled.
// Errors name the path and line of every problem, e.g.
//   "steps[2].call (line 9): missing 'operation'".

#include <google/protobuf/struct.pb.h>

#include <cstdint>
#include <string>
#include <utility>
#include <variant>
#include <vector>

#include "urs/camus_server/result.hpp"
#include "urs/camus_server/topic_pattern.hpp"

namespace urs::camus_server {

struct CallStep {
  std::string service;
  std::string operation;
  std::string args_json = "{}";
  uint32_t deadline_ms = 0;  // 0 = the service's / server's default
};

struct WaitEventStep {
  TopicPattern pattern;
  uint32_t timeout_ms = 0;
  // Dotted field paths into the event payload (as JSON with .proto field names) and the value
  // each must equal.
  std::vector<std::pair<std::string, google::protobuf::Value>> match;
};

struct WaitContextStep {
  std::string key;
  bool has_equals = false;
  google::protobuf::Value equals;
  bool exists = true;  // without `equals`: wait until the key exists (true) or is absent (false)
  uint32_t timeout_ms = 0;
};

struct SleepStep {
  uint32_t ms = 0;
};

// An event the task publishes (source: the server), typed: `type` is the full Protobuf name of a
// message some registered interface describes, `payload_json` its value in Protobuf's JSON form.
struct PublishStep {
  std::string topic;
  std::string type;
  std::string payload_json = "{}";
};

struct TaskStep {
  std::variant<CallStep, WaitEventStep, WaitContextStep, SleepStep, PublishStep> action;
  int line = 0;  // 1-based line in the YAML text
  // "call robot1.navigation.moveTo", "wait_event robot1.navigation/arrived", "sleep 500 ms",
  // "publish kr/door (URS.DoorEvent)", ...
  std::string summary() const;
};

struct TaskSpec {
  std::string name;
  std::string description;
  uint32_t repeat = 1;
  std::string trigger;  // event pattern text; empty = no trigger
  TopicPattern trigger_pattern;
  std::vector<TaskStep> steps;
};

// BAD_ARGUMENTS "task 'n': <problem>; <problem>..." listing every problem found.
// `default_name` is used when the YAML has no `name`.
Result<TaskSpec> parse_task(const std::string& yaml, const std::string& default_name);

// Empty if `name` is a valid task name, else why not.
std::string task_name_problem(const std::string& name);

// JSON text of a YAML value: quoted scalars are strings; plain scalars become null, booleans and
// numbers where YAML 1.2's core schema says so, strings otherwise.
std::string yaml_text_to_json(const std::string& yaml);

}  // namespace urs::camus_server
