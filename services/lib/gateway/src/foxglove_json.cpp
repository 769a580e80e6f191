#include "urs/gateway/foxglove_json.hpp"

#include <google/protobuf/struct.pb.h>
#include <google/protobuf/util/json_util.h>

#include <set>

#include "urs/schema/json.hpp"

namespace urs::gateway {

namespace gp = google::protobuf;
using FD = gp::FieldDescriptor;

bool travels_as_json_text(const gp::Descriptor& type) {
  return type.full_name() == "google.protobuf.Value" || type.full_name() == "google.protobuf.ListValue";
}

namespace {

bool well_known(const gp::Descriptor& type) { return type.file()->name().rfind("google/protobuf/", 0) == 0; }

bool has_json_text(const gp::Descriptor& type, std::set<const gp::Descriptor*>& seen) {
  if (!seen.insert(&type).second) return false;
  for (int i = 0; i < type.field_count(); ++i) {
    const gp::Descriptor* nested = type.field(i)->message_type();
    if (nested == nullptr) continue;
    if (travels_as_json_text(*nested)) return true;
    if (!well_known(*nested) && has_json_text(*nested, seen)) return true;
  }
  return false;
}

// Rewrites, in the JSON value `json` of a message of `type`, every field that travels as JSON
// text: to text (`to_text`) or back. Returns "" or the first error, naming the field by `where`.
class Rewriter {
 public:
  explicit Rewriter(bool to_text) : to_text_(to_text) {}

  std::string message(gp::Value& json, const gp::Descriptor& type, const std::string& where) {
    if (json.kind_case() != gp::Value::kStructValue) return {};  // json_to_message says what is wrong
    auto& fields = *json.mutable_struct_value()->mutable_fields();
    for (int i = 0; i < type.field_count(); ++i) {
      const FD& field = *type.field(i);
      const gp::Descriptor* nested = field.message_type();
      if (nested == nullptr) continue;
      auto it = fields.find(field.name());
      if (it == fields.end()) it = fields.find(field.json_name());
      if (it == fields.end()) continue;
      const std::string path = where.empty() ? field.name() : where + "." + field.name();
      gp::Value& value = it->second;
      std::string error;
      if (field.is_map()) {
        const FD& map_value = *nested->map_value();
        if (map_value.message_type() == nullptr || value.kind_case() != gp::Value::kStructValue) continue;
        for (auto& [key, entry] : *value.mutable_struct_value()->mutable_fields()) {
          error = single(entry, *map_value.message_type(), path + "[" + key + "]");
          if (!error.empty()) return error;
        }
      } else if (field.is_repeated()) {
        if (value.kind_case() != gp::Value::kListValue) continue;
        auto& items = *value.mutable_list_value()->mutable_values();
        for (int k = 0; k < items.size(); ++k) {
          error = single(items[k], *nested, path + "[" + std::to_string(k) + "]");
          if (!error.empty()) return error;
        }
      } else {
        error = single(value, *nested, path);
        if (!error.empty()) return error;
      }
    }
    return {};
  }

 private:
  std::string single(gp::Value& value, const gp::Descriptor& type, const std::string& where) {
    if (travels_as_json_text(type)) return to_text_ ? text_of(value, where) : value_of(value, type, where);
    if (well_known(type)) return {};
    return message(value, type, where);
  }

  static std::string text_of(gp::Value& value, const std::string& where) {
    std::string text;
    if (!gp::util::MessageToJsonString(value, &text).ok()) return where + ": cannot be printed as JSON";
    value.set_string_value(std::move(text));
    return {};
  }

  static std::string value_of(gp::Value& value, const gp::Descriptor& type, const std::string& where) {
    if (value.kind_case() != gp::Value::kStringValue) return {};  // the value itself
    gp::Value parsed;
    const auto status = gp::util::JsonStringToMessage(value.string_value(), &parsed);
    if (!status.ok()) {
      return where + ": not JSON text (a " + type.full_name() +
             " is sent as its JSON text): " + std::string(status.message());
    }
    value = std::move(parsed);
    return {};
  }

  const bool to_text_;
};

std::string rewrite(const std::string& json, const gp::Descriptor& type, bool to_text, std::string& out) {
  if (!has_json_text_fields(type)) {
    out = json;
    return {};
  }
  gp::Value tree;
  const auto status = gp::util::JsonStringToMessage(json, &tree);
  if (!status.ok()) return "JSON for " + type.full_name() + ": " + std::string(status.message());
  std::string error = Rewriter(to_text).message(tree, type, "");
  if (!error.empty()) return "JSON for " + type.full_name() + ": " + error;
  out.clear();
  if (!gp::util::MessageToJsonString(tree, &out).ok()) return "JSON for " + type.full_name() + ": cannot be printed";
  return {};
}

}  // namespace

bool has_json_text_fields(const gp::Descriptor& type) {
  std::set<const gp::Descriptor*> seen;
  return has_json_text(type, seen);
}

std::string to_foxglove_json(const std::string& canonical, const gp::Descriptor& type, std::string& out) {
  return rewrite(canonical, type, true, out);
}

std::string to_foxglove_json(const gp::Message& message, std::string& out) {
  std::string canonical;
  std::string error = schema::message_to_json(message, canonical);
  if (!error.empty()) return error;
  return to_foxglove_json(canonical, *message.GetDescriptor(), out);
}

std::string from_foxglove_json(const std::string& json, const gp::Descriptor& type, std::string& out) {
  return rewrite(json, type, false, out);
}

}  // namespace urs::gateway
