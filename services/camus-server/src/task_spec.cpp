#include "urs/camus_server/task_spec.hpp"

#include <google/protobuf/util/json_util.h>
#include <yaml-cpp/yaml.h>

#include <charconv>
#include <cmath>
#include <regex>
#include <set>

#include "urs/camus_server/names.hpp"
#include "urs/schema/json.hpp"
#include "urs/util/json_text.hpp"

namespace urs::camus_server {

namespace gp = google::protobuf;

namespace {

void append_plain_scalar(std::string& out, const std::string& text) {
  static const std::set<std::string> nulls{"", "~", "null", "Null", "NULL"};
  static const std::set<std::string> trues{"true", "True", "TRUE"};
  static const std::set<std::string> falses{"false", "False", "FALSE"};
  static const std::regex integer("[-+]?[0-9]+");
  static const std::regex decimal("[-+]?(\\.[0-9]+|[0-9]+(\\.[0-9]*)?)([eE][-+]?[0-9]+)?");
  if (nulls.count(text) != 0) {
    out += "null";
  } else if (trues.count(text) != 0) {
    out += "true";
  } else if (falses.count(text) != 0) {
    out += "false";
  } else if (std::regex_match(text, integer)) {
    out += text[0] == '+' ? text.substr(1) : text;
  } else if (std::regex_match(text, decimal)) {
    double value = std::strtod(text.c_str(), nullptr);
    if (!std::isfinite(value)) {
      out += util::json_string(text);
      return;
    }
    char buf[64];
    auto [end, ec] = std::to_chars(buf, buf + sizeof buf, value);
    out.append(buf, ec == std::errc() ? end : buf);
  } else {
    out += util::json_string(text);
  }
}

// Appends `open`, what `append_item` appends for each item of `node` (a sequence or a map), comma
// separated, then `close`.
template <typename AppendItem>
void append_each(std::string& out, char open, const YAML::Node& node, char close, AppendItem append_item) {
  out += open;
  bool first = true;
  for (const auto& item : node) {
    if (!first) out += ',';
    first = false;
    append_item(item);
  }
  out += close;
}

void append_json(std::string& out, const YAML::Node& node) {
  switch (node.Type()) {
    case YAML::NodeType::Undefined:
    case YAML::NodeType::Null:
      out += "null";
      return;
    case YAML::NodeType::Scalar:
      if (node.Tag() == "!") {
        out += util::json_string(node.Scalar());  // quoted: always a string
      } else {
        append_plain_scalar(out, node.Scalar());
      }
      return;
    case YAML::NodeType::Sequence:
      append_each(out, '[', node, ']', [&out](const auto& item) { append_json(out, item); });
      return;
    case YAML::NodeType::Map:
      append_each(out, '{', node, '}', [&out](const auto& item) {
        out += util::json_string(item.first.Scalar());
        out += ':';
        append_json(out, item.second);
      });
      return;
  }
}

std::string to_json(const YAML::Node& node) {
  std::string out;
  append_json(out, node);
  return out;
}

// Collects problems with their path and line.
class Problems {
 public:
  void add(const std::string& path, const YAML::Node& node, const std::string& what) {
    std::string where = path;
    if (node.IsDefined() && node.Mark().line >= 0) where += " (line " + std::to_string(node.Mark().line + 1) + ")";
    list_.push_back(where + ": " + what);
  }
  bool empty() const { return list_.empty(); }
  std::string joined() const {
    std::string out;
    for (const auto& p : list_) out += (out.empty() ? "" : "; ") + p;
    return out;
  }

 private:
  std::vector<std::string> list_;
};

std::string quoted(const YAML::Node& node) {
  if (node.IsScalar()) return "'" + node.Scalar() + "'";
  if (node.IsMap()) return "a map";
  if (node.IsSequence()) return "a list";
  return "nothing";
}

bool is_map(const YAML::Node& node, const std::string& path, Problems& problems) {
  if (node.IsMap()) return true;
  problems.add(path, node, "expected a map, got " + quoted(node));
  return false;
}

void check_keys(const YAML::Node& map, const std::string& path, const std::vector<std::string>& allowed,
                Problems& problems) {
  for (const auto& item : map) {
    const std::string key = item.first.Scalar();
    bool known = false;
    for (const auto& a : allowed) known = known || a == key;
    if (!known) {
      std::string list;
      for (const auto& a : allowed) list += (list.empty() ? "" : ", ") + a;
      problems.add(path + "." + key, item.first, "unknown key " + quote_prefix(key) + " (expected " + list + ")");
    }
  }
}

bool read_string(const YAML::Node& map, const std::string& key, const std::string& path, bool required,
                 std::string& out, Problems& problems) {
  YAML::Node node = map[key];
  if (!node.IsDefined() || node.IsNull()) {
    if (required) problems.add(path, map, "missing '" + key + "'");
    return false;
  }
  if (!node.IsScalar() || node.Scalar().empty()) {
    problems.add(path + "." + key, node, "expected a non-empty text, got " + quoted(node));
    return false;
  }
  out = node.Scalar();
  return true;
}

bool read_uint(const YAML::Node& map, const std::string& key, const std::string& path, bool required, uint64_t min,
               uint64_t max, const std::string& unit, uint32_t& out, Problems& problems) {
  YAML::Node node = map[key];
  if (!node.IsDefined() || node.IsNull()) {
    if (required) problems.add(path, map, "missing '" + key + "'");
    return false;
  }
  const std::string text = node.IsScalar() ? node.Scalar() : std::string();
  uint64_t value = 0;
  auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (text.empty() || ec != std::errc() || end != text.data() + text.size() || value < min || value > max) {
    problems.add(path + "." + key, node,
                 quoted(node) + " is not " + unit + " (" + std::to_string(min) + ".." + std::to_string(max) + ")");
    return false;
  }
  out = static_cast<uint32_t>(value);
  return true;
}

constexpr uint64_t kMaxMs = 0xFFFFFFFFull;

bool to_value(const YAML::Node& node, const std::string& path, gp::Value& out, Problems& problems) {
  auto status = gp::util::JsonStringToMessage(to_json(node), &out);
  if (!status.ok()) {
    problems.add(path, node, "cannot be used as a value: " + std::string(status.message()));
    return false;
  }
  return true;
}

// An optional map under `key` as JSON text into `out` (left as it is when absent or null).
void read_json_map(const YAML::Node& body, const std::string& key, const std::string& path, const std::string& what,
                   std::string& out, Problems& problems) {
  const YAML::Node node = body[key];
  if (!node.IsDefined() || node.IsNull()) return;
  if (node.IsMap()) {
    out = to_json(node);
  } else {
    problems.add(path + "." + key, node, "expected a map of " + what + ", got " + quoted(node));
  }
}

void parse_call(const YAML::Node& body, const std::string& path, TaskStep& step, Problems& problems) {
  CallStep call;
  if (!is_map(body, path, problems)) return;
  check_keys(body, path, {"service", "operation", "args", "deadline_ms"}, problems);
  read_string(body, "service", path, true, call.service, problems);
  read_string(body, "operation", path, true, call.operation, problems);
  read_json_map(body, "args", path, "request fields", call.args_json, problems);
  read_uint(body, "deadline_ms", path, false, 1, kMaxMs, "a number of milliseconds", call.deadline_ms, problems);
  step.action = std::move(call);
}

void parse_wait_event(const YAML::Node& body, const std::string& path, TaskStep& step, Problems& problems) {
  WaitEventStep wait;
  if (!is_map(body, path, problems)) return;
  check_keys(body, path, {"pattern", "timeout_ms", "match"}, problems);
  std::string pattern;
  if (read_string(body, "pattern", path, true, pattern, problems)) {
    auto parsed = TopicPattern::parse(pattern);
    if (parsed.ok()) {
      wait.pattern = parsed.value();
    } else {
      problems.add(path + ".pattern", body["pattern"], parsed.message());
    }
  }
  read_uint(body, "timeout_ms", path, false, 0, kMaxMs, "a number of milliseconds", wait.timeout_ms, problems);
  YAML::Node match = body["match"];
  if (match.IsDefined() && !match.IsNull()) {
    if (match.IsMap()) {
      for (const auto& item : match) {
        gp::Value value;
        std::string field = item.first.Scalar();
        if (to_value(item.second, path + ".match." + field, value, problems)) wait.match.emplace_back(field, value);
      }
    } else {
      problems.add(path + ".match", match, "expected a map of field: value, got " + quoted(match));
    }
  }
  step.action = std::move(wait);
}

void parse_wait_context(const YAML::Node& body, const std::string& path, TaskStep& step, Problems& problems) {
  WaitContextStep wait;
  if (!is_map(body, path, problems)) return;
  check_keys(body, path, {"key", "equals", "exists", "timeout_ms"}, problems);
  if (read_string(body, "key", path, true, wait.key, problems)) {
    if (auto why = topic_problem(wait.key); !why.empty()) {
      problems.add(path + ".key", body["key"], "context key " + quote_prefix(wait.key) + " is not valid: " + why);
    }
  }
  YAML::Node equals = body["equals"];
  YAML::Node exists = body["exists"];
  if (equals.IsDefined() && exists.IsDefined()) {
    problems.add(path, body, "give either 'equals' or 'exists', not both");
  } else if (equals.IsDefined()) {
    wait.has_equals = to_value(equals, path + ".equals", wait.equals, problems);
  } else if (exists.IsDefined()) {
    const std::string text = exists.IsScalar() ? exists.Scalar() : std::string();
    if (text == "true" || text == "True" || text == "TRUE") {
      wait.exists = true;
    } else if (text == "false" || text == "False" || text == "FALSE") {
      wait.exists = false;
    } else {
      problems.add(path + ".exists", exists, quoted(exists) + " is not true or false");
    }
  } else {
    problems.add(path, body, "missing 'equals' or 'exists'");
  }
  read_uint(body, "timeout_ms", path, false, 0, kMaxMs, "a number of milliseconds", wait.timeout_ms, problems);
  step.action = std::move(wait);
}

void parse_sleep(const YAML::Node& body, const std::string& path, TaskStep& step, Problems& problems) {
  SleepStep sleep;
  if (!is_map(body, path, problems)) return;
  check_keys(body, path, {"ms"}, problems);
  read_uint(body, "ms", path, true, 0, kMaxMs, "a number of milliseconds", sleep.ms, problems);
  step.action = sleep;
}

void parse_publish(const YAML::Node& body, const std::string& path, TaskStep& step, Problems& problems) {
  PublishStep publish;
  if (!is_map(body, path, problems)) return;
  check_keys(body, path, {"topic", "type", "payload"}, problems);
  if (read_string(body, "topic", path, true, publish.topic, problems)) {
    if (auto why = topic_problem(publish.topic); !why.empty()) {
      problems.add(path + ".topic", body["topic"], "topic " + quote_prefix(publish.topic) + " is not valid: " + why);
    } else if (is_server_topic(publish.topic)) {
      // A task publishes as its owner, who may not speak as the server.
      problems.add(path + ".topic", body["topic"],
                   "topics under '" + publish.topic.substr(0, publish.topic.find('/')) +
                       "/' are published by the server alone (registry/, context/ and task/ are server topics)");
    }
  }
  read_string(body, "type", path, true, publish.type, problems);
  read_json_map(body, "payload", path, "the event's fields", publish.payload_json, problems);
  step.action = std::move(publish);
}

}  // namespace

std::string TaskStep::summary() const {
  struct Visitor {
    std::string operator()(const CallStep& s) const { return "call " + s.service + "." + s.operation; }
    std::string operator()(const WaitEventStep& s) const { return "wait_event " + s.pattern.text(); }
    std::string operator()(const WaitContextStep& s) const { return "wait_context " + s.key; }
    std::string operator()(const SleepStep& s) const { return "sleep " + std::to_string(s.ms) + " ms"; }
    std::string operator()(const PublishStep& s) const { return "publish " + s.topic + " (" + s.type + ")"; }
  };
  return std::visit(Visitor{}, action);
}

std::string task_name_problem(const std::string& name) {
  if (name.empty()) return "it is empty";
  if (name.size() > 100) return "it is longer than 100 characters";
  for (char c : name) {
    bool ok =
        (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '.' || c == '_' || c == '-';
    if (!ok) return std::string("character '") + c + "' is not allowed (use letters, digits and . _ -)";
  }
  return {};
}

std::string yaml_text_to_json(const std::string& yaml) { return to_json(YAML::Load(yaml)); }

Result<TaskSpec> parse_task(const std::string& yaml, const std::string& default_name) {
  YAML::Node root;
  std::string label = default_name.empty() ? std::string("(unnamed)") : default_name;
  try {
    root = YAML::Load(yaml);
  } catch (const YAML::Exception& e) {
    return make_error(planet::BAD_ARGUMENTS, "task '" + label + "': YAML does not parse: line " +
                                                 std::to_string(e.mark.line + 1) + ", column " +
                                                 std::to_string(e.mark.column + 1) + ": " + e.msg);
  }
  if (!root.IsMap()) {
    return make_error(planet::BAD_ARGUMENTS, "task '" + label + "': expected a map with 'steps', got " + quoted(root));
  }

  TaskSpec spec;
  Problems problems;
  check_keys(root, "task", {"name", "description", "repeat", "trigger", "steps"}, problems);
  YAML::Node name = root["name"];
  if (name.IsDefined() && !name.IsNull()) {
    spec.name = name.IsScalar() ? name.Scalar() : std::string();
    if (auto why = task_name_problem(spec.name); !why.empty()) {
      problems.add("name", name, "task name " + quoted(name) + " is not valid: " + why);
    }
  } else {
    spec.name = default_name;
    if (auto why = task_name_problem(spec.name); !why.empty()) problems.add("name", root, "missing 'name'");
  }
  if (task_name_problem(spec.name).empty()) label = spec.name;
  read_string(root, "description", "task", false, spec.description, problems);
  read_uint(root, "repeat", "task", false, 1, 1000000, "a repeat count", spec.repeat, problems);

  YAML::Node trigger = root["trigger"];
  if (trigger.IsDefined() && !trigger.IsNull() && is_map(trigger, "trigger", problems)) {
    check_keys(trigger, "trigger", {"event"}, problems);
    if (read_string(trigger, "event", "trigger", true, spec.trigger, problems)) {
      auto parsed = TopicPattern::parse(spec.trigger);
      if (parsed.ok()) {
        spec.trigger_pattern = parsed.value();
      } else {
        problems.add("trigger.event", trigger["event"], parsed.message());
      }
    }
  }

  YAML::Node steps = root["steps"];
  if (!steps.IsDefined() || steps.IsNull()) {
    problems.add("task", root, "missing 'steps'");
  } else if (!steps.IsSequence() || steps.size() == 0) {
    problems.add("steps", steps, "expected a non-empty list of steps, got " + quoted(steps));
  } else {
    for (size_t i = 0; i < steps.size(); ++i) {
      const YAML::Node& item = steps[i];
      std::string path = "steps[" + std::to_string(i) + "]";
      TaskStep step;
      step.line = item.Mark().line + 1;
      if (!item.IsMap() || item.size() != 1) {
        problems.add(path, item, "a step is a map with exactly one of call, wait_event, wait_context, sleep, publish");
        continue;
      }
      auto action = item.begin();
      const std::string kind = action->first.Scalar();
      const YAML::Node body = action->second;
      if (kind == "call") {
        parse_call(body, path + ".call", step, problems);
      } else if (kind == "wait_event") {
        parse_wait_event(body, path + ".wait_event", step, problems);
      } else if (kind == "wait_context") {
        parse_wait_context(body, path + ".wait_context", step, problems);
      } else if (kind == "sleep") {
        parse_sleep(body, path + ".sleep", step, problems);
      } else if (kind == "publish") {
        parse_publish(body, path + ".publish", step, problems);
      } else {
        problems.add(path, item,
                     "unknown step '" + kind + "' (expected call, wait_event, wait_context, sleep or publish)");
        continue;
      }
      spec.steps.push_back(std::move(step));
    }
  }
  if (!problems.empty()) return make_error(planet::BAD_ARGUMENTS, "task '" + label + "': " + problems.joined());
  return spec;
}

}  // namespace urs::camus_server
