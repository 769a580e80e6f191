#pragma once
// The JSON the gateway's Foxglove side speaks for a Protobuf message (docs/dashboard.md, "Schema
// rules"): the canonical JSON mapping of urs::schema (IDL field names, every field printed, 64-bit
// integers as decimal strings, enums by name, bytes as base64), except for the fields of type
// google.protobuf.Value and ListValue — any JSON, which no schema Foxglove or Lichtblick reads can
// describe — which travel as a string holding their JSON text. The schema json_schema() writes for
// a type describes exactly what to_foxglove_json() prints.
//
// from_foxglove_json() reads it back: such a field given as a string is parsed as JSON text; given
// as any other JSON value, that value is taken as is (so clients that send the value itself keep
// working). Thread-safe; never throws; every error names the field.

#include <google/protobuf/descriptor.h>
#include <google/protobuf/message.h>

#include <string>

namespace urs::gateway {

// True for google.protobuf.Value and google.protobuf.ListValue.
bool travels_as_json_text(const google::protobuf::Descriptor& type);
// True if `type` has such a field, at any depth: only then do the two functions below differ
// from the canonical mapping.
bool has_json_text_fields(const google::protobuf::Descriptor& type);

// `message` as the Foxglove side prints it. Returns "" on success, else what went wrong.
std::string to_foxglove_json(const google::protobuf::Message& message, std::string& out);
// Canonical JSON text of a message of `type` (urs::schema::message_to_json) as the Foxglove side
// prints it. Returns "" on success.
std::string to_foxglove_json(const std::string& canonical, const google::protobuf::Descriptor& type, std::string& out);
// JSON text from a Foxglove client for a message of `type` turned into the canonical mapping
// (what urs::schema::json_to_message reads). Returns "" on success, else e.g.
// "value: not JSON text (a google.protobuf.Value is sent as its JSON text): ...".
std::string from_foxglove_json(const std::string& json, const google::protobuf::Descriptor& type, std::string& out);

}  // namespace urs::gateway
