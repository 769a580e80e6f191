#include "urs/camus_server/event_match.hpp"

#include <google/protobuf/util/json_util.h>
#include <google/protobuf/util/message_differencer.h>

#include <cstdlib>
#include <optional>

namespace urs::camus_server {

namespace gp = google::protobuf;

namespace {

std::optional<double> as_number(const gp::Value& value) {
  if (value.kind_case() == gp::Value::kNumberValue) return value.number_value();
  if (value.kind_case() == gp::Value::kStringValue) {
    const std::string& text = value.string_value();
    if (text.empty()) return std::nullopt;
    char* end = nullptr;
    double parsed = std::strtod(text.c_str(), &end);
    if (end != text.c_str() + text.size()) return std::nullopt;
    return parsed;
  }
  return std::nullopt;
}

const gp::Value* find_path(const gp::Struct& root, const std::string& path) {
  const gp::Struct* current = &root;
  const gp::Value* found = nullptr;
  size_t start = 0;
  for (;;) {
    size_t dot = path.find('.', start);
    std::string name = path.substr(start, dot == std::string::npos ? std::string::npos : dot - start);
    auto it = current->fields().find(name);
    if (it == current->fields().end()) return nullptr;
    found = &it->second;
    if (dot == std::string::npos) return found;
    if (found->kind_case() != gp::Value::kStructValue) return nullptr;
    current = &found->struct_value();
    start = dot + 1;
  }
}

}  // namespace

bool values_equal(const gp::Value& a, const gp::Value& b) {
  if (a.kind_case() == b.kind_case()) return gp::util::MessageDifferencer::Equals(a, b);
  auto x = as_number(a);
  auto y = as_number(b);
  return x && y && *x == *y;
}

bool event_matches(const planet::Event& event, const std::vector<std::pair<std::string, gp::Value>>& match,
                   const SchemaLookup& schemas) {
  if (match.empty()) return true;
  std::string json;
  const std::string& type = event.content_type();
  if (type == "application/json") {
    json = event.payload();
  } else if (!type.empty()) {
    auto schema = schemas.schema_with_message(type);
    const gp::Descriptor* descriptor = schema ? schema->find_message(type) : nullptr;
    if (descriptor == nullptr) return false;
    auto converted = schema->payload_to_json(*descriptor, event.payload());
    if (!converted.ok()) return false;
    json = std::move(converted.value());
  } else {
    return false;
  }
  gp::Struct payload;
  if (!gp::util::JsonStringToMessage(json, &payload).ok()) return false;
  for (const auto& [path, expected] : match) {
    const gp::Value* actual = find_path(payload, path);
    if (actual == nullptr || !values_equal(*actual, expected)) return false;
  }
  return true;
}

}  // namespace urs::camus_server
