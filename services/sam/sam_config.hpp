#pragma once
// urs-sam configuration (YAML), validated once into an immutable struct. See docs/camus.md.
//
//   name: sam-lab              # optional; the SAM's peer name (default sam@<hostname>)
//   workers: 4                 # optional; threads running agent calls (default 4)
//   agents:
//     - name: diag-{host}      # service name in the space; {host} is replaced by the host name
//       type: diagnostic       # one of the agent types this binary knows
//       deadline_ms: 5000      # optional default deadline advertised for the service
//       properties: {room: lab}
//       params: {}             # agent-specific settings, passed to the agent's factory

#include <yaml-cpp/yaml.h>

#include <cstdint>
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
  std::vector<AgentConfig> agents;
};

// Parses and validates `path`. Throws urs::util::ConfigError listing EVERY problem found, each
// with its key path and value (e.g. "agents[1].type: unknown agent type 'foo' (known: diagnostic)").
SamConfig load_sam_config(const std::string& path, const std::set<std::string>& known_types,
                          const std::string& host);

}  // namespace urs::sam
