#include "urs/rtc/manager.hpp"

#include <spdlog/spdlog.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <set>

#include "urs/rtc/execution_context.hpp"
#include "urs/rtc/naming.hpp"
#include "urs/rtc/orb.hpp"
#include "urs/rtc/tools.hpp"
#include "urs/util/cli.hpp"
#include "urs/util/yaml_config.hpp"

namespace urs::rtc {
namespace {

// How many instance numbers a manager tries before it gives up on finding a free name.
constexpr int kMaxInstances = 1000;

std::string format_rate(double rate) {
  std::string text = std::to_string(rate);
  text.erase(text.find_last_not_of('0') + 1);
  if (!text.empty() && text.back() == '.') text.pop_back();
  return text;
}

}  // namespace

Manager::Manager(Orb& orb, NamingClient& naming, ManagerOptions options)
    : orb_(orb), naming_(naming), options_(std::move(options)) {
  if (options_.host.empty()) options_.host = util::host_name();
}

Manager::~Manager() { shutdown(); }

void Manager::add_factory(const std::string& type, ComponentFactory factory) {
  std::lock_guard lock(mutex_);
  factories_[type] = std::move(factory);
}

std::string Manager::naming_path(const Component& component) const {
  return component_path(options_.host, component.instance_name());
}

Component& Manager::create(const ComponentSpec& spec) {
  ComponentFactory factory;
  {
    std::lock_guard lock(mutex_);
    auto it = factories_.find(spec.type);
    if (it == factories_.end()) {
      std::set<std::string> known;
      for (const auto& [type, f] : factories_) known.insert(type);
      throw util::ConfigError("unknown component type '" + spec.type + "' (known: " + util::join(known) + ")");
    }
    factory = it->second;
  }
  return create(spec, factory);
}

Component& Manager::create(const ComponentSpec& spec, const ComponentFactory& factory) {
  const double rate = spec.rate_hz > 0 ? spec.rate_hz : options_.default_rate_hz;
  const ComponentEnv env{orb_, naming_, options_};

  // Try instance numbers until one binds: a name is usable if nothing is bound there or the
  // object bound there no longer exists. bind() is atomic in the naming service, so two
  // managers racing for the same name cannot both win.
  for (int n = 0; n < kMaxInstances; ++n) {
    const std::string instance = spec.instance_name.empty() ? spec.type + std::to_string(n) : spec.instance_name;
    const std::string path = component_path(options_.host, instance);
    CORBA::Object_var existing = naming_.try_resolve(path);
    const bool stale = !CORBA::is_nil(existing) && is_gone(existing);
    if (!CORBA::is_nil(existing) && !stale) {
      if (!spec.instance_name.empty()) {
        throw std::runtime_error("instance name " + instance + " is already bound to a live component at " + path);
      }
      continue;
    }

    std::unique_ptr<Component> component = factory(spec.config, env);
    std::vector<std::pair<std::string, std::string>> properties{{"naming.names", path},
                                                                {"urslink.space", options_.space},
                                                                {"urslink.host", options_.host},
                                                                {"exec_cxt.periodic.rate", format_rate(rate)},
                                                                {"pid", std::to_string(getpid())}};
    properties.insert(properties.end(), spec.properties.begin(), spec.properties.end());
    component->setup(orb_, instance, rate, properties);
    component->serve_while_inactive(spec.serve_while_inactive);
    const RTC::ReturnCode_t init = component->initialize();
    if (init != RTC::RTC_OK) {
      component->exit();
      throw std::runtime_error(spec.type + " " + instance + ": initialize returned " + return_code_name(init));
    }
    RTC::RTObject_var self = component->reference();
    try {
      if (stale) {
        spdlog::info("{}: replacing a stale binding (its object no longer exists)", path);
        naming_.rebind(path, self);
      } else {
        naming_.bind(path, self);
      }
    } catch (const NamingError& e) {
      component->exit();
      if (spec.instance_name.empty() && std::string(e.what()).find("already bound") != std::string::npos) {
        continue;  // another manager took this name in the meantime
      }
      throw;
    }
    spdlog::info("{} bound at {} (rate {} Hz)", instance, path, format_rate(rate));

    Component& created = *component;
    {
      std::lock_guard lock(mutex_);
      hosted_.push_back({std::move(component), path});
    }
    auto owned = std::make_shared<RTC::RTObject_var>(RTC::RTObject::_duplicate(self.in()));
    created.on_exit([this, path, owned]() {
      try {
        CORBA::Object_var bound = naming_.try_resolve(path);
        if (!CORBA::is_nil(bound) && bound->_is_equivalent(owned->in())) naming_.unbind(path);
      } catch (const std::exception& e) {
        spdlog::warn("{}: could not remove the binding: {}", path, e.what());
      }
    });
    if (spec.activate) {
      RTC::ExecutionContextService_var context = created.execution_context().reference();
      const RTC::ReturnCode_t result = context->activate_component(self);
      if (result != RTC::RTC_OK) {
        throw std::runtime_error(instance + ": activation returned " + return_code_name(result));
      }
    }
    return created;
  }
  throw std::runtime_error("no free instance name for " + spec.type + " under " + options_.host + ".host_cxt after " +
                           std::to_string(kMaxInstances) + " tries");
}

bool Manager::destroy(Component& component) {
  Hosted hosted;
  {
    std::lock_guard lock(mutex_);
    auto it = std::find_if(hosted_.begin(), hosted_.end(),
                           [&component](const Hosted& h) { return h.component.get() == &component; });
    if (it == hosted_.end()) return false;
    hosted = std::move(*it);
    hosted_.erase(it);
  }
  if (!hosted.component->exited()) hosted.component->exit();  // removes the binding through on_exit
  return true;
}

void Manager::shutdown() {
  std::vector<Hosted> hosted;
  {
    std::lock_guard lock(mutex_);
    hosted.swap(hosted_);
  }
  // Exit in reverse order of creation; exit() removes the binding through on_exit.
  for (auto it = hosted.rbegin(); it != hosted.rend(); ++it) {
    if (!it->component->exited()) it->component->exit();
  }
}

ManagerConfig load_manager_config(const std::string& path) {
  const YAML::Node root = util::load_yaml_file(path, "--config");
  if (!root.IsMap()) throw util::ConfigError("--config: '" + path + "' must be a YAML map with a 'components' list");
  std::vector<std::string> errors;
  ManagerConfig config;
  util::check_keys(root, "", {"rate", "plugins", "plugin_path", "components"}, errors);
  util::read_string_list(root, "plugins", config.plugins, errors);
  util::read_folder_list(root, "plugin_path", config.plugin_path, errors);
  auto read_rate = [&](const YAML::Node& node, const std::string& where, double& out) {
    if (util::read_scalar(node, where, out, errors) && !(out > 0 && std::isfinite(out))) {
      errors.push_back(where + ": " + YAML::Dump(node) + " is not a positive rate in Hz");
    }
  };
  if (root["rate"]) read_rate(root["rate"], "rate", config.rate_hz);
  const YAML::Node components = root["components"];
  if (!components || !components.IsSequence()) {
    errors.push_back("components: a list of components is required");
  } else {
    util::for_each_map(components, "components", "at least a type",
                       {"type", "instance", "rate", "activate", "serve_while_inactive", "config"}, errors,
                       [&](const YAML::Node& node, const std::string& where) {
                         ComponentSpec spec;
                         if (!node["type"]) {
                           errors.push_back(where + ".type: missing");
                         } else {
                           util::read_scalar(node["type"], where + ".type", spec.type, errors);
                         }
                         if (node["instance"])
                           util::read_scalar(node["instance"], where + ".instance", spec.instance_name, errors);
                         if (node["rate"]) read_rate(node["rate"], where + ".rate", spec.rate_hz);
                         if (node["activate"])
                           util::read_scalar(node["activate"], where + ".activate", spec.activate, errors);
                         if (node["serve_while_inactive"]) {
                           util::read_scalar(node["serve_while_inactive"], where + ".serve_while_inactive",
                                             spec.serve_while_inactive, errors);
                         }
                         if (node["config"]) spec.config = node["config"];
                         config.components.push_back(std::move(spec));
                       });
  }
  util::throw_if_errors(errors, "--config '" + path + "'");
  return config;
}

}  // namespace urs::rtc
