#include "urs/bridge/space_state.hpp"

#include <google/protobuf/struct.pb.h>
#include <spdlog/spdlog.h>

#include "camus.pb.h"
#include "urs/schema/json.hpp"

namespace urs::bridge {

namespace {

namespace gp = google::protobuf;
using SystemClock = std::chrono::system_clock;

constexpr auto kCamusTimeout = std::chrono::milliseconds(2000);
constexpr const char* kContextPrefix = "context/";
constexpr const char* kImportedSource = "dds:";  // origin of imported context entries: "dds:<space>"

SystemClock::time_point from_unix_ns(int64_t ns) {
  return SystemClock::time_point(std::chrono::duration_cast<SystemClock::duration>(std::chrono::nanoseconds(ns)));
}
int64_t unix_ns(SystemClock::time_point t) {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(t.time_since_epoch()).count();
}

// An object of string fields, for the component entries written into CAMUS.
gp::Value string_object(const std::vector<std::pair<std::string, std::string>>& fields) {
  gp::Value object;
  auto& members = *object.mutable_struct_value()->mutable_fields();
  for (const auto& [name, value] : fields) members[name].set_string_value(value);
  return object;
}

}  // namespace

SpaceState::SpaceState(const BridgeConfig& config, DdsLink& link, planet::Client* client)
    : config_(config), client_(client) {
  const StateConfig& state = config_.dds.state;
  const bool import = client_ != nullptr && state.import;
  StateHandlers handlers;
  if (import) {
    handlers.component = [this](const ComponentState& c, bool alive) {
      const std::string key = c.space + "/component/" + c.name;
      if (!alive) return import_delete(key);
      import_set(key, c.space,
                 string_object({{"kind", c.kind}, {"state", c.state}, {"type_name", c.type_name}, {"host", c.host}}));
    };
    handlers.context = [this](const ContextState& e, bool alive) {
      const std::string key = e.space + "/" + e.key;
      if (!alive) return import_delete(key);
      gp::Value value;
      if (const std::string error = schema::json_to_message(e.value_json, value); !error.empty()) {
        spdlog::warn("bridge: the value of {} from another space is not JSON: {}", key, error);
        return;
      }
      import_set(key, e.space, std::move(value));
    };
    handlers.pose = [this](const SpacePose& pose) { import_pose(pose); };
    handlers.event = [this](const SpaceEvent& event) { import_event(event); };
    clear_stale_imports();
  }
  link_ = std::make_unique<StateLink>(link, std::move(handlers), state.poses);

  if (client_ == nullptr) return;
  // Events arrive on the Planet client's I/O thread: the DDS writes happen on the exporter's.
  for (const auto& pattern : state.events) {
    subscriptions_.push_back(client_->subscribe(pattern, [this](const planet::Event& e) {
      exporter_.post([this, e](bool cancelled) {
        if (!cancelled) export_event(e);
      });
    }));
  }
  if (!state.context_allow.empty()) {
    subscriptions_.push_back(client_->subscribe(std::string(kContextPrefix) + "#", [this](const planet::Event& e) {
      exporter_.post([this, e](bool cancelled) {
        if (!cancelled) export_context(e);
      });
    }));
    // What the context holds already (the subscription brings the changes from now on).
    importer_.post([this](bool cancelled) {
      if (cancelled) return;
      camus::ContextListRequest request;
      const auto listed = client_->call("camus.context", "List", request.SerializeAsString(), kCamusTimeout);
      camus::ContextListReply reply;
      if (!listed.ok() || !reply.ParseFromString(listed.payload)) {
        spdlog::warn("bridge: cannot list the CAMUS context to share it: {} {}", planet::status_name(listed.status),
                     listed.message);
        return;
      }
      for (const auto& entry : reply.entries()) {
        planet::Event event;
        event.set_topic(kContextPrefix + entry.key());
        event.set_payload(entry.SerializeAsString());
        export_context(event);
      }
    });
  }
}

SpaceState::~SpaceState() {
  if (client_) {
    for (uint64_t id : subscriptions_) client_->unsubscribe(id);
  }
  exporter_.stop();
  link_.reset();
  importer_.stop();
}

bool SpaceState::rtc_states_due() {
  const auto now = std::chrono::steady_clock::now();
  if (now - rtcs_read_at_ < config_.dds.state.period) return false;
  rtcs_read_at_ = now;
  return config_.dds.state.components;
}

void SpaceState::rtc_states(const std::vector<ComponentState>& now) { sync(rtcs_, now); }

void SpaceState::agent_states(const std::vector<ComponentState>& now) {
  if (config_.dds.state.components) sync(agents_, now);
}

void SpaceState::sync(std::set<std::string>& shared, const std::vector<ComponentState>& now) {
  std::set<std::string> seen;
  for (const auto& state : now) {
    link_->set_component(state);
    seen.insert(state.name);
  }
  for (const auto& name : shared) {
    if (!seen.count(name)) link_->drop_component(name);
  }
  shared = std::move(seen);
}

// ---- out: this space's CAMUS events and context ----

void SpaceState::export_event(const planet::Event& event) {
  // Imported events (published by this bridge on <space>/...) are not shared again; context has
  // its own topic.
  if (event.topic().rfind(kContextPrefix, 0) == 0) return;
  if (event.source() == client_->welcome().identity()) {
    std::lock_guard lock(spaces_mutex_);
    if (imported_spaces_.count(event.topic().substr(0, event.topic().find('/')))) return;
  }
  SpaceEvent shared{"", event.seq(), event.topic(), event.content_type(), event.source(),
                    from_unix_ns(event.time_unix_ns()), event.payload()};
  if (!link_->publish_event(shared)) {
    spdlog::error("bridge: event {} on {} not shared over DDS: its history is full (the other spaces' bridges do "
                  "not keep up)",
                  event.seq(), event.topic());
  }
}

void SpaceState::export_context(const planet::Event& event) {
  const std::string key = event.topic().substr(std::string(kContextPrefix).size());
  if (!allowed(key, config_.dds.state.context_allow, config_.dds.state.context_deny)) return;
  camus::ContextEntry entry;
  if (!entry.ParseFromString(event.payload())) {
    spdlog::warn("bridge: context change {} is not a ContextEntry; not shared", key);
    return;
  }
  // Imported from another space, removed (or expired), or now holding another space's value: no
  // longer this space's to share. drop_context() ends only a key this bridge shared, so the
  // removal of an imported key is never shared either.
  if (entry.value().has_null_value() || entry.origin().rfind(kImportedSource, 0) == 0) {
    link_->drop_context(key);
    return;
  }
  ContextState shared;
  shared.key = key;
  shared.source = entry.source();
  shared.version = entry.version();
  shared.stamp = from_unix_ns(entry.updated_unix_ns());
  if (const std::string error = schema::message_to_json(entry.value(), shared.value_json); !error.empty()) {
    spdlog::warn("bridge: context {} cannot be shared: {}", key, error);
    return;
  }
  link_->set_context(shared);
}

// ---- in: the other spaces' state into this space's CAMUS ----

// On the importer thread: `key` set in this space's context, as coming from `space`.
planet::CallResult SpaceState::set_imported(const std::string& key, const std::string& space, const gp::Value& value) {
  camus::ContextSetRequest request;
  request.set_key(key);
  request.set_source(kImportedSource + space);
  *request.mutable_value() = value;
  return client_->call("camus.context", "Set", request.SerializeAsString(), kCamusTimeout);
}

void SpaceState::import_set(const std::string& key, const std::string& space, gp::Value value) {
  importer_.post([this, key, space, value = std::move(value)](bool cancelled) {
    if (cancelled) return;
    const auto result = set_imported(key, space, value);
    if (!result.ok()) {
      spdlog::warn("bridge: context {} from another space not set: {} {}", key, planet::status_name(result.status),
                   result.message);
    }
  });
}

void SpaceState::import_delete(const std::string& key) {
  importer_.post([this, key](bool cancelled) {
    if (cancelled) return;
    camus::ContextDeleteRequest request;
    request.set_key(key);
    const auto result = client_->call("camus.context", "Delete", request.SerializeAsString(), kCamusTimeout);
    if (!result.ok() && result.status != planet::NOT_FOUND) {
      spdlog::warn("bridge: context {} of another space not removed: {} {}", key, planet::status_name(result.status),
                   result.message);
    }
  });
}

// Poses come faster than context writes may be worth: only the newest of each robot waits.
void SpaceState::import_pose(const SpacePose& pose) {
  const std::string key = pose.space + "/pose/" + pose.robot;
  gp::Value value;
  auto& fields = *value.mutable_struct_value()->mutable_fields();
  fields["x"].set_number_value(pose.x);
  fields["y"].set_number_value(pose.y);
  fields["theta"].set_number_value(pose.theta);
  fields["stamp_unix_ns"].set_number_value(static_cast<double>(unix_ns(pose.stamp)));
  {
    std::lock_guard lock(poses_mutex_);
    const bool waiting = poses_.count(key) != 0;
    poses_[key] = std::move(value);
    if (waiting) return;
  }
  importer_.post([this, key, space = pose.space](bool cancelled) {
    gp::Value newest;
    {
      std::lock_guard lock(poses_mutex_);
      newest = std::move(poses_[key]);
      poses_.erase(key);
    }
    if (cancelled) return;
    const auto result = set_imported(key, space, newest);
    if (!result.ok()) spdlog::debug("bridge: pose {} not set: {}", key, result.message);
  });
}

void SpaceState::import_event(const SpaceEvent& event) {
  {
    std::lock_guard lock(spaces_mutex_);
    imported_spaces_.insert(event.space);
  }
  importer_.post([this, event](bool cancelled) {
    const std::string topic = event.space + "/" + event.topic;
    if (cancelled) {
      spdlog::warn("bridge: stopping before event {} of space {} was published as {}", event.seq, event.space, topic);
      return;
    }
    const auto result = client_->publish(topic, event.payload, event.content_type);
    if (!result.ok()) {
      spdlog::warn("bridge: event {} of space {} not published as {}: {} {}", event.seq, event.space, topic,
                   planet::status_name(result.status), result.message);
    }
  });
}

// Entries a previous run of this bridge imported: whatever still holds comes back over DDS.
void SpaceState::clear_stale_imports() {
  importer_.post([this](bool cancelled) {
    if (cancelled) return;
    camus::ContextListRequest request;
    const auto listed = client_->call("camus.context", "List", request.SerializeAsString(), kCamusTimeout);
    camus::ContextListReply reply;
    if (!listed.ok() || !reply.ParseFromString(listed.payload)) return;
    for (const auto& entry : reply.entries()) {
      if (entry.origin().rfind(kImportedSource, 0) != 0) continue;
      camus::ContextDeleteRequest remove;
      remove.set_key(entry.key());
      client_->call("camus.context", "Delete", remove.SerializeAsString(), kCamusTimeout);
    }
  });
}

}  // namespace urs::bridge
