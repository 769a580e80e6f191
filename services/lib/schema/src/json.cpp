#include "urs/schema/json.hpp"

#include <google/protobuf/util/json_util.h>

#include <cstdint>
#include <cstdio>

namespace urs::schema {

namespace gp = google::protobuf;

std::string json_to_message(const std::string& json, gp::Message& out) {
  gp::util::JsonParseOptions options;
  options.ignore_unknown_fields = false;
  const gp::util::Status status = gp::util::JsonStringToMessage(json, &out, options);
  if (status.ok()) return {};
  return "JSON for " + out.GetDescriptor()->full_name() + ": " + std::string(status.message());
}

std::string message_to_json(const gp::Message& msg, std::string& out, bool pretty) {
  gp::util::JsonPrintOptions options;
  options.add_whitespace = pretty;
  options.always_print_primitive_fields = true;
  options.preserve_proto_field_names = true;
  out.clear();
  const gp::util::Status status = gp::util::MessageToJsonString(msg, &out, options);
  if (status.ok()) return {};
  out.clear();
  return "JSON of " + msg.GetDescriptor()->full_name() + ": " + std::string(status.message());
}

}  // namespace urs::schema
