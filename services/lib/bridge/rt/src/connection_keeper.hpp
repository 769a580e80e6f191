#pragma once
// ConnectionKeeper: the connections of the bridge's RTCs kept across restarts (internal; the file
// is a ConnectionStore, docs/bridge.md "Restarts"). At a session's opening, what was saved becomes
// connections to restore (in a new process, after the peers dropped their stale halves); each RT
// poll restores those whose RTC is back and saves what the bridge's RTCs hold.
//
// Threads: the bridge's thread only.

#include <chrono>
#include <functional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "urs/bridge/rt/connection_store.hpp"
#include "urs/rtc/component.hpp"
#include "urs/rtc/orb.hpp"

namespace urs::bridge {

class ConnectionKeeper {
 public:
  // `path` "" keeps nothing. `connector_name` is the profile name of the connections the bridge's
  // own discovery makes (its rules make them again: they are not restored).
  ConnectionKeeper(rtc::Orb& orb, std::string path, std::string connector_name);

  // What was saved becomes the connections to restore; the first time in a process, the peers
  // are first told to drop the halves they hold of them.
  void load();
  // The bridge's RTC for a SavedConnection::rtc key ("bridge", or a stand-in's source); nullptr
  // if it is not there now.
  using FindRtc = std::function<rtc::Component*(const std::string& key)>;
  // Makes again the saved connections whose RTC is back (a failure is tried again later).
  void restore(const FindRtc& find);
  // Saves what `rtcs` (key, component) hold, with what is still to restore.
  void save(const std::vector<std::pair<std::string, rtc::Component*>>& rtcs);

 private:
  struct Restore {
    SavedConnection saved;
    std::chrono::steady_clock::time_point retry_at;
  };
  rtc::Orb& orb_;
  ConnectionStore store_;
  const std::string connector_name_;
  bool stale_halves_dropped_ = false;  // once per process, at its first session
  std::vector<Restore> restores_;      // saved connections not made again yet
  std::set<std::string> warned_;       // restores whose failure was logged
};

}  // namespace urs::bridge
