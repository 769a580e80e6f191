#pragma once
// JSON <-> Protobuf messages with Protobuf's canonical JSON mapping (google::protobuf::util).
// Works on generated and dynamic messages alike. Mapping reminders: 64-bit integers print as JSON
// strings (both strings and numbers are accepted), bytes are base64, enums print as their names
// (e.g. "IMAGE_ENCODING_PNG"), both the IDL field names and their lowerCamelCase forms are accepted.
// Thread-safe; never throws on bad input.

#include <google/protobuf/message.h>

#include <string>
#include <string_view>

namespace urs::schema {

// Replaces the content of `out` with `json` (a JSON object). Returns "" on success, else a
// message naming the message type and the offending field or value, e.g.
// "JSON for URS.Diagnostic_add_Request: (a): invalid value \"x\" for type TYPE_DOUBLE".
// Unknown fields are errors. On error `out` holds unspecified (but valid) content.
std::string json_to_message(const std::string& json, google::protobuf::Message& out);

// Sets `out` to the JSON form of `msg`, with the IDL field names and every primitive field
// printed (even when 0/""/false). pretty: indented, multi-line. Returns "" on success.
std::string message_to_json(const google::protobuf::Message& msg, std::string& out, bool pretty = false);

}  // namespace urs::schema
