#pragma once
// StateLink: the state one space's bridge shares with the other spaces over DDS, besides the
// service catalog and calls of DdsLink (idl/dds/SpaceState.idl, docs/federation.md):
//
//   urs/state/component  RT-Component lifecycle states and CAMUS agents of this space
//   urs/state/pose       this space's robot poses, relayed from its own devices' DDS domain
//   urs/state/context    CAMUS context entries
//   urs/state/event      CAMUS events
//
// It writes this space's state on the DdsLink's participant and hands the other spaces' state to
// its handlers. Components and context are keyed state: a writer's entries end ("gone") when it
// disposes them or when its bridge is lost (liveliness, lease), and come back with the bridge.
//
// Each space speaks only for itself: a sample naming a space is handed over only if its writer may
// speak for that space (DdsLink::speaks_for: on a secured link, the space its participant proved
// with its certificate; on a plain link whatever it names); others are dropped, logged once.
//
// Threads: the component and context handlers run on StateLink's own reader thread, which reads
// the readers' caches when DDS reports a change and every quarter lease; the pose and event
// handlers on Fast DDS's listener threads, one sample at a time. None may block. The writing
// methods may be called from any thread.

#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "urs/federation/dds_link.hpp"

namespace urs::federation {

// Robot poses of this space's devices (urs/localizer/pose or urs/world/pose in their own DDS
// domain, idl/dds/WorldState.idl) relayed to the other spaces, each robot at most every `period`.
struct PoseRelay {
  uint32_t domain = 1;        // the devices' domain: must differ from the link's
  bool ground_truth = false;  // false: the localizers' measurements
  std::vector<std::string> robots;
  std::chrono::milliseconds period{100};
};

struct ComponentState {
  std::string space;      // filled in on what arrives; this space's on what is written
  std::string name;       // naming path of an RTC, or CAMUS service name
  std::string kind;       // "rtc" or "agent"
  std::string state;      // rtc: Created Inactive Active Error Unreachable; agent: Available
  std::string type_name;  // rtc: type_name; agent: interface
  std::string host;       // rtc: host naming context; agent: its SAM
  std::chrono::system_clock::time_point stamp;
  bool operator==(const ComponentState& o) const {
    return space == o.space && name == o.name && kind == o.kind && state == o.state && type_name == o.type_name &&
           host == o.host;
  }
};

struct SpacePose {
  std::string space;
  std::string robot;
  double x = 0, y = 0, theta = 0;  // m, m, rad
  std::chrono::system_clock::time_point stamp;
};

struct ContextState {
  std::string space;
  std::string key;
  std::string value_json;
  std::string source;
  uint64_t version = 0;
  std::chrono::system_clock::time_point stamp;
};

struct SpaceEvent {
  std::string space;
  uint64_t seq = 0;
  std::string topic;
  std::string content_type;
  std::string source;
  std::chrono::system_clock::time_point stamp;
  std::string payload;
};

struct StateHandlers {
  // `alive` false: the component left its space, or its space's bridge was lost.
  std::function<void(const ComponentState&, bool alive)> component;
  std::function<void(const SpacePose&)> pose;
  // `alive` false: the key was removed in its space, or its space's bridge was lost.
  std::function<void(const ContextState&, bool alive)> context;
  std::function<void(const SpaceEvent&)> event;
};

class StateLink {
 public:
  // Creates the state topics on `link`'s participant (and, with `poses`, joins the devices'
  // domain). `link` outlives this. Throws std::runtime_error if DDS refuses.
  StateLink(DdsLink& link, StateHandlers handlers, std::optional<PoseRelay> poses);
  ~StateLink();
  StateLink(const StateLink&) = delete;
  StateLink& operator=(const StateLink&) = delete;

  // This space's components: written when new or changed; `drop` disposes one.
  void set_component(ComponentState state);
  void drop_component(const std::string& name);

  // This space's context entries: written when set; `drop` ends one this link shared (a tombstone)
  // and ignores any other key, so a removal never shares a key that was not shared before.
  void set_context(ContextState entry);
  void drop_context(const std::string& key);

  // False if DDS refused the sample (its history full of samples not yet acknowledged).
  bool publish_event(const SpaceEvent& event);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace urs::federation
