#include "sam_config.hpp"

#include <spdlog/spdlog.h>

#include "urs/util/cli.hpp"
#include "urs/util/yaml_config.hpp"

namespace urs::sam {

namespace {

using util::check_keys;
using util::join;
using util::read_scalar;

std::string substitute(std::string text, const std::string& host) {
  const std::string token = "{host}";
  for (auto pos = text.find(token); pos != std::string::npos; pos = text.find(token, pos + host.size())) {
    text.replace(pos, token.size(), host);
  }
  return text;
}

}  // namespace

SamConfig load_sam_config(const std::string& path, const std::string& host,
                          const std::function<AgentTypes(const SamConfig& partial)>& load_types) {
  const YAML::Node root = util::load_yaml_file(path, "--config");
  if (!root.IsMap()) throw util::ConfigError("--config: '" + path + "' must be a YAML map with an 'agents' list");

  std::vector<std::string> errors;
  SamConfig config;
  config.name = "sam@" + host;
  check_keys(root, "", {"name", "workers", "plugins", "plugin_path", "agents"}, errors);
  if (root["name"]) read_scalar(root["name"], "name", config.name, errors);
  if (root["workers"]) {
    int workers = 0;
    if (read_scalar(root["workers"], "workers", workers, errors)) {
      if (workers < 1 || workers > 256) {
        errors.push_back("workers: " + std::to_string(workers) + " is outside 1..256");
      } else {
        config.workers = static_cast<unsigned>(workers);
      }
    }
  }
  bool plugins_ok = util::read_string_list(root, "plugins", config.plugins, errors);
  if (!util::read_folder_list(root, "plugin_path", config.plugin_path, errors)) plugins_ok = false;
  if (!plugins_ok) {
    config.plugins.clear();
    config.plugin_path.clear();
  }
  const AgentTypes types = load_types(config);
  const std::set<std::string> refused(types.refused.begin(), types.refused.end());
  std::set<std::string> dropped;  // agents of a type a refused plug-in may have defined
  const YAML::Node agents = root["agents"];
  if (!agents || !agents.IsSequence() || agents.size() == 0) {
    errors.push_back("agents: a non-empty list of agents is required");
  } else {
    std::set<std::string> names;
    util::for_each_map(
        agents, "agents", "name and type", {"name", "type", "deadline_ms", "properties", "params"}, errors,
        [&](const YAML::Node& node, const std::string& where) {
          AgentConfig agent;
          if (!node["name"] || !read_scalar(node["name"], where + ".name", agent.name, errors) || agent.name.empty()) {
            if (!node["name"]) errors.push_back(where + ".name: missing");
          } else {
            agent.name = substitute(agent.name, host);
            if (!names.insert(agent.name).second) {
              errors.push_back(where + ".name: '" + agent.name + "' is used by another agent");
            }
          }
          if (!node["type"]) {
            errors.push_back(where + ".type: missing (known: " + join(types.known) + ")");
          } else if (read_scalar(node["type"], where + ".type", agent.type, errors) &&
                     types.known.count(agent.type) == 0) {
            const std::string problem =
                where + ".type: unknown agent type '" + agent.type + "' (known: " + join(types.known) + ")";
            if (refused.empty()) {
              errors.push_back(problem);
            } else {
              spdlog::error("--config '{}': {}; agent '{}' not hosted (refused plug-in(s): {})", path, problem,
                            agent.name, join(refused));
              dropped.insert(where);
            }
          }
          if (node["deadline_ms"]) read_scalar(node["deadline_ms"], where + ".deadline_ms", agent.deadline_ms, errors);
          if (node["properties"]) {
            if (!node["properties"].IsMap()) {
              errors.push_back(where + ".properties: must be a map of strings");
            } else {
              for (const auto& kv : node["properties"]) {
                std::string value;
                if (read_scalar(kv.second, where + ".properties." + kv.first.as<std::string>(), value, errors)) {
                  agent.properties[kv.first.as<std::string>()] = substitute(value, host);
                }
              }
            }
          }
          agent.params = node["params"] ? node["params"] : YAML::Node(YAML::NodeType::Map);
          if (dropped.count(where) == 0) config.agents.push_back(std::move(agent));
        });
  }
  util::throw_if_errors(errors, "--config '" + path + "'");
  return config;
}

SamConfig load_sam_config(const std::string& path, const std::set<std::string>& known_types, const std::string& host) {
  return load_sam_config(path, host, [&known_types](const SamConfig&) { return AgentTypes{known_types, {}}; });
}

}  // namespace urs::sam
