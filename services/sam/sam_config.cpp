#include "sam_config.hpp"

#include <sstream>

#include "urs/util/cli.hpp"

namespace urs::sam {

namespace {

std::string join(const std::set<std::string>& items) {
  std::string out;
  for (const auto& item : items) out += (out.empty() ? "" : ", ") + item;
  return out;
}

std::string substitute(std::string text, const std::string& host) {
  const std::string token = "{host}";
  for (auto pos = text.find(token); pos != std::string::npos; pos = text.find(token, pos + host.size())) {
    text.replace(pos, token.size(), host);
  }
  return text;
}

template <class T>
bool read_scalar(const YAML::Node& node, const std::string& where, T& out, std::vector<std::string>& errors) {
  try {
    out = node.as<T>();
    return true;
  } catch (const YAML::Exception&) {
    errors.push_back(where + ": '" + YAML::Dump(node) + "' is not a valid value");
    return false;
  }
}

void check_keys(const YAML::Node& node, const std::string& where, const std::set<std::string>& allowed,
                std::vector<std::string>& errors) {
  for (const auto& kv : node) {
    auto key = kv.first.as<std::string>();
    if (allowed.count(key) == 0) {
      errors.push_back(where + (where.empty() ? "" : ".") + key + ": unknown key (allowed: " + join(allowed) + ")");
    }
  }
}

}  // namespace

SamConfig load_sam_config(const std::string& path, const std::set<std::string>& known_types,
                          const std::string& host) {
  YAML::Node root;
  try {
    root = YAML::LoadFile(path);
  } catch (const YAML::BadFile&) {
    throw util::ConfigError("--config: cannot read '" + path + "'");
  } catch (const YAML::Exception& e) {
    throw util::ConfigError("--config: '" + path + "' is not valid YAML: " + e.what());
  }
  if (!root.IsMap()) throw util::ConfigError("--config: '" + path + "' must be a YAML map with an 'agents' list");

  std::vector<std::string> errors;
  SamConfig config;
  config.name = "sam@" + host;
  check_keys(root, "", {"name", "workers", "agents"}, errors);
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
  const YAML::Node agents = root["agents"];
  if (!agents || !agents.IsSequence() || agents.size() == 0) {
    errors.push_back("agents: a non-empty list of agents is required");
  } else {
    std::set<std::string> names;
    for (std::size_t i = 0; i < agents.size(); ++i) {
      const std::string where = "agents[" + std::to_string(i) + "]";
      const YAML::Node node = agents[i];
      if (!node.IsMap()) {
        errors.push_back(where + ": must be a map with name and type");
        continue;
      }
      check_keys(node, where, {"name", "type", "deadline_ms", "properties", "params"}, errors);
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
        errors.push_back(where + ".type: missing (known: " + join(known_types) + ")");
      } else if (read_scalar(node["type"], where + ".type", agent.type, errors) &&
                 known_types.count(agent.type) == 0) {
        errors.push_back(where + ".type: unknown agent type '" + agent.type + "' (known: " + join(known_types) + ")");
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
      config.agents.push_back(std::move(agent));
    }
  }
  if (!errors.empty()) {
    std::ostringstream out;
    out << "--config '" << path << "' has " << errors.size() << " error(s):";
    for (const auto& e : errors) out << "\n  " << e;
    throw util::ConfigError(out.str());
  }
  return config;
}

}  // namespace urs::sam
