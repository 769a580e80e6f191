#pragma once
// urs-sam configuration (YAML), validated once into an immutable struct. See docs/camus.md.
//
//   name: sam-lab              # optional; the SAM's peer name (default sam@<hostname>)
//   workers: 4                 # optional; threads running agent calls (default 4)
//   plugins: [calculator, /opt/lab/libgripper.so]   # optional; agent plug-ins (docs/sdk.md)
//   plugin_path: [/opt/lab/plugins]                  # optional; folders searched before URS_PLUGIN_PATH
//   agents:
//     - name: diag-{host}      # service name in the space; {host} is replaced by the host name
//       type: diagnostic       # one of the agent types this binary knows
//       deadline_ms: 5000      # optional default deadline advertised for the service
//       properties: {room: lab}
//       params: {}             # agent-specific settings, passed to the agent's factory

#include <yaml-cpp/yaml.h>

#include <cstdint>
#include <functional>
#include <map>
#include <set>
#include <string>
#include <vector>

namespace urs::sam {

struct AgentConfig {
  std::string name;
  std::string type;
  uint32_t deadline_ms = 0;
  std::map<std::string, std::string> properties;
  YAML::Node params;
};

struct SamConfig {
  std::string name;
  unsigned workers = 4;
  std::vector<std::string> plugins;      // as written: a path (with a '/') or a name to search
  std::vector<std::string> plugin_path;  // existing folders
  std::vector<AgentConfig> agents;
};

// Parses and validates `path`. Throws urs::util::ConfigError listing EVERY problem found, each
// with its key path and value (e.g. "agents[1].type: unknown agent type 'foo' (known: diagnostic)").
SamConfig load_sam_config(const std::string& path, const std::set<std::string>& known_types, const std::string& host);

// What the SAM can host once the plug-ins are loaded.
struct AgentTypes {
  std::set<std::string> known;       // built-in and plug-in agent types
  std::vector<std::string> refused;  // paths of the plug-ins refused
};

// The same, for a SAM that loads plug-ins: `load_types` is called once, after `plugins:` and
// `plugin_path:` are read (with both empty if either is invalid) and before the agents' types are
// checked. When a plug-in was refused, an agent of an unknown type is dropped with an error in the
// log rather than refused: the SAM keeps its other agents.
SamConfig load_sam_config(const std::string& path, const std::string& host,
                          const std::function<AgentTypes(const SamConfig& partial)>& load_types);

}  // namespace urs::sam
