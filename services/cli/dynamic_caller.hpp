#pragma once
// Calls any operation of any registered service from JSON, using the interface description the
// registry hands out (no per-interface code), and renders replies, exceptions and events as JSON.

#include <google/protobuf/descriptor.h>

#include <chrono>
#include <map>
#include <memory>
#include <string>

#include "urs/planet/client.hpp"
#include "urs/schema/schema.hpp"

namespace urs::cli {

struct CallOutput {
  planet::CallResult result;
  std::string json;  // reply (OK) or exception (USER_EXCEPTION) as JSON; empty otherwise
};

class DynamicCaller {
 public:
  explicit DynamicCaller(planet::Client& client, std::chrono::milliseconds timeout)
      : client_(client), timeout_(timeout) {}

  // Resolves service → interface → method, converts `json_args` (may be empty = "{}"), calls,
  // and decodes the answer. Local failures (bad JSON, unknown operation) come back as
  // BAD_ARGUMENTS / UNKNOWN_OPERATION results with a precise message.
  CallOutput call(const std::string& service, const std::string& operation, const std::string& json_args,
                  std::chrono::milliseconds deadline);

  // "<service> implements <interface> (<repository id>)", then one line per operation as IDL
  // declares it (schema::idl_signature), or an error result.
  planet::CallResult describe(const std::string& service, std::string& out);

  // The message type `full_name` as the space knows it: compiled in (urs.camus.*, google.protobuf.*),
  // already loaded, or described by a registered interface (camus.registry Describe by type; a
  // type the registry does not know is asked again after 5 s at the earliest). nullptr if unknown.
  const google::protobuf::Descriptor* find_type(const std::string& full_name);
  // A new message of a type find_type() returned.
  std::unique_ptr<google::protobuf::Message> new_message(const google::protobuf::Descriptor& type) const;

  // The payload of an event as JSON if its content type is known (find_type; application/json as
  // it is), else {"base64": ...}.
  std::string event_payload_json(const std::string& content_type, const std::string& payload);

  // One event as a JSON object: seq, topic, source, time_unix_ns, content_type, payload.
  std::string event_json(const planet::Event& event);

 private:
  planet::CallResult load_interface_of(const std::string& service, std::string& interface_name);

  planet::Client& client_;
  std::chrono::milliseconds timeout_;
  schema::SchemaPool pool_;
  std::map<std::string, std::string> interface_of_;
  std::map<std::string, std::chrono::steady_clock::time_point> unknown_types_;  // type -> ask again after
};

}  // namespace urs::cli
