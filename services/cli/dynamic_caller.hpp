#pragma once
// Calls any operation of any registered service from JSON, using the interface description the
// registry hands out (no per-interface code), and renders replies, exceptions and events as JSON.

#include <google/protobuf/descriptor.h>

#include <map>
#include <string>

#include "urs/planet/client.hpp"
#include "urs/schema/schema.hpp"

namespace urs::cli {

struct CallOutput {
  planet::CallResult result;
  std::string json;   // reply (OK) or exception (USER_EXCEPTION) as JSON; empty otherwise
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

  // "OPERATION(REQUEST) -> REPLY" lines of the service's interface, or an error result.
  planet::CallResult describe(const std::string& service, std::string& out);

  // The payload of an event as JSON if its content type is known (compiled in, or described by
  // some registered interface), else a JSON string holding base64.
  std::string event_payload_json(const std::string& content_type, const std::string& payload);

  // One event as a JSON object: seq, topic, source, time_unix_ns, content_type, payload.
  std::string event_json(const planet::Event& event);

 private:
  planet::CallResult load_interface_of(const std::string& service, std::string& interface_name);
  void load_all_interfaces();

  planet::Client& client_;
  std::chrono::milliseconds timeout_;
  schema::SchemaPool pool_;
  std::map<std::string, std::string> interface_of_;
  bool loaded_all_ = false;
};

}  // namespace urs::cli
