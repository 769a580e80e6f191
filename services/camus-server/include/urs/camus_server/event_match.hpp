#pragma once
// Matching an event's payload against the fields a task's wait_event step (or trigger) asks for.

#include <google/protobuf/struct.pb.h>

#include <string>
#include <utility>
#include <vector>

#include "planet.pb.h"
#include "urs/camus_server/registry.hpp"

namespace urs::camus_server {

// True if every (dotted path, value) of `match` is found in the event payload (decoded through
// its content type: "application/json" or a message type known to `schemas`).
bool event_matches(const planet::Event& event,
                   const std::vector<std::pair<std::string, google::protobuf::Value>>& match,
                   const SchemaLookup& schemas);

// Equality of two values; a number also equals a text holding the same number (int64 fields
// appear as text in JSON).
bool values_equal(const google::protobuf::Value& a, const google::protobuf::Value& b);

}  // namespace urs::camus_server
