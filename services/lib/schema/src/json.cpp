#include <google/protobuf/util/json_util.h>

#include "urs/schema/json.hpp"

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

std::string json_quote(std::string_view text) {
  std::string out;
  out.reserve(text.size() + 2);
  out += '"';
  for (unsigned char c : text) {
    switch (c) {
      case '"': out += "\\\""; break;
      case '\\': out += "\\\\"; break;
      case '\n': out += "\\n"; break;
      case '\r': out += "\\r"; break;
      case '\t': out += "\\t"; break;
      case '\b': out += "\\b"; break;
      case '\f': out += "\\f"; break;
      default:
        if (c < 0x20) {
          char escaped[8];
          std::snprintf(escaped, sizeof escaped, "\\u%04x", c);
          out += escaped;
        } else {
          out += static_cast<char>(c);
        }
    }
  }
  out += '"';
  return out;
}

std::string base64(std::string_view data) {
  static const char* alphabet = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((data.size() + 2) / 3 * 4);
  std::size_t i = 0;
  for (; i + 2 < data.size(); i += 3) {
    const uint32_t n = (uint8_t(data[i]) << 16) | (uint8_t(data[i + 1]) << 8) | uint8_t(data[i + 2]);
    for (int shift = 18; shift >= 0; shift -= 6) out += alphabet[(n >> shift) & 63];
  }
  if (i < data.size()) {
    uint32_t n = uint8_t(data[i]) << 16;
    if (i + 1 < data.size()) n |= uint8_t(data[i + 1]) << 8;
    out += alphabet[(n >> 18) & 63];
    out += alphabet[(n >> 12) & 63];
    out += i + 1 < data.size() ? alphabet[(n >> 6) & 63] : '=';
    out += '=';
  }
  return out;
}

}  // namespace urs::schema
