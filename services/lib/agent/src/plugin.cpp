#include "urs/agent/plugin.hpp"

#include <dlfcn.h>
#include <spdlog/spdlog.h>
#include <sys/stat.h>

#include <algorithm>
#include <cstdlib>
#include <map>
#include <stdexcept>
#include <utility>

namespace urs::agent {

namespace {

bool is_regular_file(const std::string& path) {
  struct stat info {};
  return ::stat(path.c_str(), &info) == 0 && S_ISREG(info.st_mode);
}

std::string joined(const std::vector<std::string>& items) {
  std::string out;
  for (const auto& item : items) out += (out.empty() ? "" : ", ") + item;
  return out.empty() ? "none" : out;
}

std::string dl_error() {
  const char* text = ::dlerror();
  return text == nullptr ? "unknown error" : text;
}

// Collects what one plug-in adds; checked against the types the host and earlier plug-ins hold.
class Registry : public PluginRegistry {
 public:
  Registry(const std::set<std::string>& taken, const std::map<std::string, std::string>& owners)
      : taken_(taken), owners_(owners) {}

  void add(PluginAgent agent) override {
    if (agent.type.empty()) throw std::invalid_argument("an agent type with an empty name");
    if (!agent.make) throw std::invalid_argument("agent type '" + agent.type + "' has no factory");
    if (agent.component_type.empty()) agent.component_type = agent.type;
    check_free(agent.type, "agent type");
    if (agent.component_type != agent.type) check_free(agent.component_type, "component type");
    names_.insert(agent.type);
    names_.insert(agent.component_type);
    added_.push_back(std::move(agent));
  }

  std::vector<PluginAgent> take() { return std::move(added_); }

 private:
  void check_free(const std::string& name, const std::string& what) const {
    if (taken_.count(name) != 0) throw std::invalid_argument(what + " '" + name + "' is built into this program");
    if (auto it = owners_.find(name); it != owners_.end()) {
      throw std::invalid_argument(what + " '" + name + "' is already defined by the plug-in " + it->second);
    }
    if (names_.count(name) != 0) throw std::invalid_argument(what + " '" + name + "' is added twice");
  }

  const std::set<std::string>& taken_;
  const std::map<std::string, std::string>& owners_;
  std::set<std::string> names_;
  std::vector<PluginAgent> added_;
};

std::string resolve(const std::string& entry, const std::vector<std::string>& search_path) {
  if (entry.find('/') != std::string::npos) {
    if (!is_regular_file(entry)) throw std::runtime_error("no such file");
    return entry;
  }
  for (const auto& folder : search_path) {
    for (const auto& name : {entry, "lib" + entry + ".so"}) {
      const std::string candidate = folder + "/" + name;
      if (is_regular_file(candidate)) return candidate;
    }
  }
  throw std::runtime_error("not found as " + entry + " or lib" + entry + ".so in the plug-in search path (" +
                           joined(search_path) + ")");
}

// Loads one plug-in; throws std::runtime_error with the reason of a refusal. The library is never
// closed: its static initializers (generated Protobuf code) ran at dlopen.
std::vector<PluginAgent> load_one(const std::string& path, const std::set<std::string>& taken,
                                  const std::map<std::string, std::string>& owners) {
  void* handle = ::dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (handle == nullptr) throw std::runtime_error("cannot be loaded: " + dl_error());
  ::dlerror();
  const auto* abi = static_cast<const UrsPluginAbi*>(::dlsym(handle, kPluginAbiSymbol));
  if (abi == nullptr) {
    throw std::runtime_error(std::string("no symbol ") + kPluginAbiSymbol +
                             " (not a URSLink plug-in, or built without URS_PLUGIN_ABI())");
  }
  if (abi->abi_version != kPluginAbiVersion) {
    throw std::runtime_error("built for plug-in ABI version " + std::to_string(abi->abi_version) +
                             ", this program loads version " + std::to_string(kPluginAbiVersion) +
                             ": rebuild it against this URSLink");
  }
  if (abi->protobuf_version != GOOGLE_PROTOBUF_VERSION) {
    throw std::runtime_error("built with Protobuf " + std::to_string(abi->protobuf_version) + ", this program uses " +
                             std::to_string(GOOGLE_PROTOBUF_VERSION) + ": rebuild it against this URSLink");
  }
  using RegisterFn = int (*)(PluginRegistry&);
  auto* register_fn = reinterpret_cast<RegisterFn>(::dlsym(handle, kPluginRegisterSymbol));
  if (register_fn == nullptr) {
    throw std::runtime_error(std::string("no symbol ") + kPluginRegisterSymbol +
                             " (declare it extern \"C\" URS_PLUGIN_EXPORT)");
  }
  Registry registry(taken, owners);
  int rc = 0;
  try {
    rc = register_fn(registry);
  } catch (const std::exception& e) {
    throw std::runtime_error(std::string(kPluginRegisterSymbol) + " failed: " + e.what());
  } catch (...) {
    throw std::runtime_error(std::string(kPluginRegisterSymbol) +
                             " failed with an exception that is not a std::exception");
  }
  if (rc != 0) throw std::runtime_error(std::string(kPluginRegisterSymbol) + " returned " + std::to_string(rc));
  auto added = registry.take();
  if (added.empty()) throw std::runtime_error("registers no agent type");
  return added;
}

}  // namespace

std::vector<std::string> plugin_search_path(const std::vector<std::string>& configured) {
  std::vector<std::string> path = configured;
  if (const char* env = std::getenv("URS_PLUGIN_PATH"); env != nullptr) {
    const std::string value = env;
    std::size_t start = 0;
    while (start <= value.size()) {
      const std::size_t end = std::min(value.find(':', start), value.size());
      if (end > start) path.push_back(value.substr(start, end - start));
      start = end + 1;
    }
  }
  return path;
}

LoadedPlugins load_plugins(const std::vector<std::string>& entries, const std::vector<std::string>& search_path,
                           const std::set<std::string>& taken_types) {
  LoadedPlugins result;
  std::map<std::string, std::string> owners;  // type or component type -> plug-in path
  for (const auto& entry : entries) {
    std::string path = entry;
    try {
      path = resolve(entry, search_path);
      auto added = load_one(path, taken_types, owners);
      std::string types;
      for (auto& agent : added) {
        owners[agent.type] = path;
        owners[agent.component_type] = path;
        types += (types.empty() ? "" : ", ") + agent.type;
        if (!agent.description.empty()) types += " (" + agent.description + ")";
        result.agents.push_back({std::move(agent), path});
      }
      result.loaded.push_back(path);
      spdlog::info("plug-in {} loaded: agent type(s) {}", path, types);
    } catch (const std::exception& e) {
      spdlog::error("plug-in {} refused: {}", path, e.what());
      result.refusals.push_back({path, e.what()});
    }
  }
  return result;
}

}  // namespace urs::agent
