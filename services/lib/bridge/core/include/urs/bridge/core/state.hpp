#pragma once
// A space's state as the sides of a bridge carry it (docs/federation.md, "Shared state"): entries
// (a key and a JSON value, as a context holds them), events, and the space's components. A side
// maps its own state to these and back; nothing here is tied to a middleware.

#include <chrono>
#include <cstdint>
#include <string>

namespace urs::bridge::core {

// An entry of a space's state: a context entry, or what another side keeps as one (another
// space's component "component/<name>", a robot's pose "pose/<robot>").
struct StateEntry {
  std::string space;       // the space it belongs to; "" for this space's
  std::string key;         // within its space
  std::string value_json;  // a JSON value
  std::string source;      // who set it, as its space says
  uint64_t version = 0;
  std::chrono::system_clock::time_point stamp;
};

// An event of a space.
struct StateEvent {
  std::string space;  // "" for this space's
  uint64_t seq = 0;   // in its space's order
  std::string topic;
  std::string content_type;  // the payload's type name
  std::string source;        // who published it, as its space says
  std::chrono::system_clock::time_point stamp;
  std::string payload;
};

// One component of this space as seen now: an RT-Component, a service agent.
struct ComponentState {
  std::string name;       // naming path of an RTC, or service name of an agent
  std::string kind;       // "rtc" or "agent"
  std::string state;      // rtc: Created Inactive Active Error Unreachable; agent: Available
  std::string type_name;  // rtc: its type_name; agent: its interface
  std::string host;       // rtc: its host naming context; agent: the service agent manager hosting it
  bool operator==(const ComponentState& o) const {
    return name == o.name && kind == o.kind && state == o.state && type_name == o.type_name && host == o.host;
  }
};

}  // namespace urs::bridge::core
