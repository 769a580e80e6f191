#pragma once
// Agent plug-ins: service agents built outside URSLink, in a shared library that urs-sam and
// urs-rtc-manager load at start-up from their configuration (`plugins:`), as OpenRTM-aist managers
// load modules. docs/sdk.md has the tutorial; examples/cpp/plugin a complete project.
//
// A plug-in is a shared library linked against the installed package (find_package(urslink),
// urslink::agent) that exports exactly two C symbols:
//
//   URS_PLUGIN_ABI();   // defines `urs_plugin_abi`, the ABI it was built for
//   extern "C" URS_PLUGIN_EXPORT int urs_plugin_register(urs::agent::PluginRegistry& registry) {
//     registry.add({"calculator", "Calculator", [](const YAML::Node& params) {
//       return std::make_shared<CalculatorAgent>(params);
//     }});
//     return 0;
//   }
//
// The host reads `urs_plugin_abi` before it runs any function of the library: a plug-in built for
// another ABI version or another Protobuf version is refused. urs_plugin_register() runs once, in
// the host's main thread; it returns 0 after adding one agent type or more. A non-zero return, an
// exception, or no agent added refuses the plug-in, and the types it added are dropped. A refused
// plug-in is named with its path and the reason in the host's log; the host keeps its other agents.
// A loaded library is never unloaded (its generated Protobuf types stay registered for the
// process's life).
//
// The ABI is C++: a plug-in must be built with the same compiler family, C++ standard library and
// Protobuf version as the host (the package's find_package(urslink) sees to the last two).

#include <google/protobuf/stubs/common.h>
#include <yaml-cpp/yaml.h>

#include <cstdint>
#include <functional>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "urs/agent/agent.hpp"

namespace urs::agent {

// Raised with every change of PluginRegistry, PluginAgent, ServiceAgent or TypedAgent that a
// plug-in built earlier would misread.
inline constexpr std::uint32_t kPluginAbiVersion = 2;

// Builds an agent from the `params:` node of its entry in the host's configuration (a null node
// when there is none). Throws urs::util::ConfigError (or any std::exception) naming the bad key:
// the host refuses that agent's entry with the message.
using AgentFactory = std::function<std::shared_ptr<ServiceAgent>(const YAML::Node& params)>;

struct PluginAgent {
  std::string type;            // the agent type configurations name (urs-sam's `agents[].type`)
  std::string component_type;  // the RT-Component type in urs-rtc-manager (empty: same as type)
  AgentFactory make;
  std::string description;  // one line, logged when the plug-in is loaded
};

class PluginRegistry {
 public:
  virtual ~PluginRegistry() = default;
  // Throws std::invalid_argument for an empty type, a type without a factory, or a type (or
  // component type) that the host or another plug-in already defines.
  virtual void add(PluginAgent agent) = 0;
};

}  // namespace urs::agent

// What urs_plugin_abi holds: C layout, read by the host before it calls into the library.
struct UrsPluginAbi {
  std::uint32_t abi_version;       // urs::agent::kPluginAbiVersion of the plug-in's build
  std::uint32_t protobuf_version;  // GOOGLE_PROTOBUF_VERSION of the plug-in's build
};

#define URS_PLUGIN_EXPORT __attribute__((visibility("default")))

// Defines the plug-in's ABI symbol; write it once, at namespace scope, in one source file.
#define URS_PLUGIN_ABI()                                                                             \
  extern "C" URS_PLUGIN_EXPORT const UrsPluginAbi urs_plugin_abi = {::urs::agent::kPluginAbiVersion, \
                                                                    GOOGLE_PROTOBUF_VERSION}

namespace urs::agent {

// The symbols a plug-in exports.
inline constexpr const char* kPluginAbiSymbol = "urs_plugin_abi";
inline constexpr const char* kPluginRegisterSymbol = "urs_plugin_register";

// An agent type a plug-in added, with the file it came from.
struct LoadedAgent {
  PluginAgent agent;
  std::string plugin;  // the plug-in's path
};

struct PluginRefusal {
  std::string path;    // as resolved (or as configured, if it could not be found)
  std::string reason;  // e.g. "no symbol urs_plugin_register: ..."
};

struct LoadedPlugins {
  std::vector<std::string> loaded;  // paths of the plug-ins accepted
  std::vector<LoadedAgent> agents;
  std::vector<PluginRefusal> refusals;
};

// The folders searched for a plug-in named without a '/': `configured` first, then each folder of
// the environment variable URS_PLUGIN_PATH (':'-separated; empty entries ignored).
std::vector<std::string> plugin_search_path(const std::vector<std::string>& configured);

// Loads each plug-in of `entries` (dlopen RTLD_NOW | RTLD_LOCAL). An entry with a '/' is a path;
// any other is a file name looked up in `search_path`, as given and then as lib<entry>.so. Each
// refusal (not found, not loadable, no symbol, ABI or Protobuf version mismatch, registration
// failed, nothing registered, a type already in `taken_types` or added by an earlier plug-in) is
// logged as an error with path and reason and listed; the other plug-ins are still loaded.
LoadedPlugins load_plugins(const std::vector<std::string>& entries, const std::vector<std::string>& search_path,
                           const std::set<std::string>& taken_types);

}  // namespace urs::agent
