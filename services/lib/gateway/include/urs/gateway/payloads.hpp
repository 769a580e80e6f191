#pragma once
// Payloads as JSON values: a serialized message of a named type (an event's payload, a call's
// reply or exception) decoded with the type's description — a type compiled into the program, or
// one described at run time (the registry's or the DDS link's descriptions, added to pool()).
// Thread-safe (SchemaPool is).

#include <google/protobuf/struct.pb.h>

#include <string>

#include "urs/schema/schema.hpp"

namespace urs::gateway {

class PayloadDecoder {
 public:
  schema::SchemaPool& pool() { return pool_; }

  // The message of type `type` (Protobuf full name; "application/json" is JSON text already) as
  // a JSON value; {"base64": "..."} when the type is unknown or the bytes are not one.
  google::protobuf::Value decode(const std::string& type, const std::string& payload) const;
  // The same as JSON text.
  std::string decode_json(const std::string& type, const std::string& payload) const;

 private:
  schema::SchemaPool pool_;
};

// A JSON value from JSON text; a null value if the text is not JSON.
google::protobuf::Value json_value(const std::string& json);

}  // namespace urs::gateway
