#pragma once
// JSON Schema (draft 2020-12) of a Protobuf message type as the gateway's Foxglove side prints and
// parses it (foxglove_json.hpp: the canonical JSON mapping of urs::schema, but for
// google.protobuf.Value and ListValue, which travel as their JSON text): what the gateway
// advertises as the schema of a channel or of a service's request and reply, so that Foxglove,
// Lichtblick and the dashboard know every field. Derived from the descriptor alone; nothing is
// written per type.
//
// Every schema stays within what the stricter of Foxglove's and Lichtblick's JSON Schema readers
// accept (docs/dashboard.md, "Schema rules"): the root and every nested object has "type":
// "object" and "properties"; every property has one "type" among boolean, string, number,
// integer, object and array; "contentEncoding" only "base64" and never inside an array; array
// items are never arrays; no "$ref", no list of types, no "null".
//
// Mapping: message -> object with one property per field under its IDL (proto) name, no other
// properties; double/float -> number; 32-bit integers -> integer (with their ranges); 64-bit
// integers -> decimal string (as printed; beyond JavaScript's exact integers); bool -> boolean;
// string -> string; bytes -> base64 string (in an array: a string with a base64 pattern); enum ->
// string, one of its value names; repeated -> array; map -> object of values; Value, ListValue ->
// string holding JSON text (contentMediaType application/json); Struct, Any -> object; Timestamp,
// Duration, FieldMask -> string; wrappers -> their value's schema. A message type met again inside
// itself (a recursive type) is an object whose properties are not listed there. Thread-safe; never
// throws.

#include <google/protobuf/descriptor.h>

#include <string>

namespace urs::gateway {

// The schema as compact JSON text, with "title" the type's full name.
std::string json_schema(const google::protobuf::Descriptor& type);

}  // namespace urs::gateway
