#pragma once
// JSON Schema (draft 2020-12) of a Protobuf message type as its canonical JSON mapping prints and
// parses it (urs::schema::json_to_message / message_to_json): what the gateway advertises as the
// schema of a channel or of a service's request and reply, so that Foxglove, Lichtblick and the
// dashboard know every field. Derived from the descriptor alone; nothing is written per type.
//
// Mapping: message -> object with one property per field under its IDL (proto) name, no other
// properties; double/float -> number; 32-bit integers -> integer (with their ranges); 64-bit
// integers -> integer or decimal string; bool -> boolean; string -> string; bytes -> base64
// string; enum -> one of its value names; repeated -> array; map -> object of values;
// google.protobuf.Value -> any JSON; Struct -> object; ListValue -> array; Timestamp, Duration,
// FieldMask -> string; wrappers -> their value or null. A message type that contains itself is
// written once under "$defs" and referred to with "$ref". Thread-safe; never throws.

#include <google/protobuf/descriptor.h>

#include <string>

namespace urs::gateway {

// The schema as compact JSON text, with "title" the type's full name.
std::string json_schema(const google::protobuf::Descriptor& type);

}  // namespace urs::gateway
