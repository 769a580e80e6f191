#pragma once
// The naming side of a watch over RT-Components, shared by the watchers (rtc::Connector, the
// bridge's RT side). The naming service sends no notifications, so a watcher polls it, and each
// poll begins with the same two steps:
//   1. read_component_bindings(): list the whole tree and resolve each "*.rtc" binding the watcher
//      is concerned with, comparing stringified IORs with the last poll; a component bound under
//      several names is taken once, under its first name in path order;
//   2. changed_bindings(): the components known from the last poll whose binding went away or now
//      names another object (a restart), for the watcher to forget.
// What a watcher then does with the components (read their profiles, probe them, connect their
// ports as its rules say) is its own: its connect strategy.

#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "urs/rtc/naming.hpp"
#include "urs/rtc/orb.hpp"

namespace urs::rtc {

struct ComponentBinding {
  std::string ior;
  CORBA::Object_var object;
};
using ComponentBindings = std::map<std::string, ComponentBinding>;  // by naming path

// Step 1. `watched` says which naming paths concern the watcher; `stopping` (optional) is asked
// between resolutions, and a true answer ends the step early (nullopt). Throws NamingError when
// the naming service cannot be read.
std::optional<ComponentBindings> read_component_bindings(NamingClient& naming, const Orb& orb,
                                                         const std::function<bool(const std::string&)>& watched,
                                                         const std::function<bool()>& stopping = {});

struct ChangedBinding {
  std::string path;
  std::string why;  // "unbound" or "rebound to another object"
};

// Step 2, over what the watcher knows by path (`ior_of` gives the IOR it last saw for an entry).
template <typename Known, typename IorOf>
std::vector<ChangedBinding> changed_bindings(const std::map<std::string, Known>& known, const ComponentBindings& bound,
                                             IorOf ior_of) {
  std::vector<ChangedBinding> changed;
  for (const auto& [path, entry] : known) {
    const auto now_bound = bound.find(path);
    if (now_bound == bound.end()) {
      changed.push_back({path, "unbound"});
    } else if (now_bound->second.ior != ior_of(entry)) {
      changed.push_back({path, "rebound to another object"});
    }
  }
  return changed;
}

}  // namespace urs::rtc
