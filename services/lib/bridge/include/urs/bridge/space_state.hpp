#pragma once
// SpaceState: a bridge's share of the state spaces exchange over DDS (StateLink), joined to its
// CAMUS session (docs/federation.md, "Shared state"):
//
//   out  this space's RT-Component lifecycle states and CAMUS agents (given by the bridge's polls),
//        its robots' poses (relayed from the devices' domain), the CAMUS context entries and
//        events the configuration allows (a subscription on the bridge's Planet session)
//   in   the other spaces' state, written into this space's CAMUS context and events:
//          <space>/component/<name>   {"kind", "state", "type_name", "host"}
//          <space>/pose/<robot>       {"x", "y", "theta", "stamp_unix_ns"}
//          <space>/<key>              the entry's value
//          events on <space>/<topic>  the event's payload and content type
//        Entries end (are deleted) when they end in their space or their space's bridge is lost.
//
// Loops: nothing imported is shared again (context entries it sets have the source
// "dds:<space>"; events it publishes on <space>/... are recognised by their topic).
// Threads: the constructor, the destructor and the *_states methods run on the bridge's thread;
// what arrives over DDS is written into CAMUS by one importer thread, and this space's events and
// context changes onto DDS by one exporter thread, each in arrival order (never on the Planet
// client's I/O thread nor on a DDS listener).

#include <google/protobuf/struct.pb.h>

#include <chrono>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <string>
#include <vector>

#include "urs/agent/agent.hpp"
#include "urs/bridge/config.hpp"
#include "urs/bridge/state_link.hpp"
#include "urs/planet/client.hpp"

namespace urs::bridge {

class SpaceState {
 public:
  // `link` and `client` (null: no CAMUS server) outlive this. Throws std::runtime_error if DDS
  // refuses the state endpoints.
  SpaceState(const BridgeConfig& config, DdsLink& link, planet::Client* client);
  ~SpaceState();
  SpaceState(const SpaceState&) = delete;
  SpaceState& operator=(const SpaceState&) = delete;

  // Every RTC (or CAMUS agent) of this space as seen now: changes are written, the missing dropped.
  void rtc_states(const std::vector<ComponentState>& now);
  void agent_states(const std::vector<ComponentState>& now);
  // True when the RTC states are due to be read again (every state.period_ms).
  bool rtc_states_due();

 private:
  void sync(std::set<std::string>& shared, const std::vector<ComponentState>& now);
  void export_event(const planet::Event& event);
  void export_context(const planet::Event& event);
  planet::CallResult set_imported(const std::string& key, const std::string& space,
                                  const google::protobuf::Value& value);
  void import_set(const std::string& key, const std::string& space, google::protobuf::Value value);
  void import_delete(const std::string& key);
  void import_pose(const SpacePose& pose);
  void import_event(const SpaceEvent& event);
  void clear_stale_imports();

  const BridgeConfig& config_;
  planet::Client* client_;
  std::set<std::string> rtcs_;    // names written, by kind
  std::set<std::string> agents_;
  std::chrono::steady_clock::time_point rtcs_read_at_;
  std::vector<uint64_t> subscriptions_;

  std::mutex spaces_mutex_;
  std::set<std::string> imported_spaces_;  // spaces whose events this bridge publishes here
  std::mutex poses_mutex_;  // the newest pose per "<space>/pose/<robot>" not yet written into CAMUS
  std::map<std::string, google::protobuf::Value> poses_;
  agent::WorkerPool importer_{1};
  agent::WorkerPool exporter_{1};  // this space's events and context changes, in order, onto DDS
  std::unique_ptr<StateLink> link_;  // last: destroyed first, so nothing arrives into the rest
};

}  // namespace urs::bridge
