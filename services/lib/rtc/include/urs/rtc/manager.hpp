#pragma once
// Hosts RT-Components in one process: creates them from a catalog of factories, initializes
// them, starts their execution contexts and binds each in the naming service under
// "<host>.host_cxt/<instance>.rtc".
//
// Naming rules (replicas never overwrite each other):
// - instance names are <TypeName><N>: the manager takes the lowest N whose name is free or bound
//   to an object that no longer exists (a stale binding, repaired); a live binding is left alone
//   and the next N is tried. An instance name given explicitly that is bound to a live object
//   is an error.
// - on shutdown (or when a component exits) the binding is removed only if it still refers to
//   that component.

#include <yaml-cpp/yaml.h>

#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "urs/rtc/component.hpp"

namespace urs::rtc {

class Orb;
class NamingClient;

struct ManagerOptions {
  std::string space;  // recorded in each component profile as urslink.space
  std::string host;   // naming context "<host>.host_cxt"; default: this machine's host name
  double default_rate_hz = 100.0;
};

// What a factory may need from the hosting process besides its own configuration.
struct ComponentEnv {
  Orb& orb;
  NamingClient& naming;  // the naming service the manager binds in
  const ManagerOptions& options;
};

// Builds a component of one type from its `config:` node (may be null). Throws
// urs::util::ConfigError for bad configuration.
using ComponentFactory = std::function<std::unique_ptr<Component>(const YAML::Node& config, const ComponentEnv& env)>;

struct ComponentSpec {
  std::string type;
  std::string instance_name;  // empty: <type><N>
  double rate_hz = 0;         // 0: the manager's default
  bool activate = false;      // activate in its own execution context once bound
  YAML::Node config;
  // Extra properties of the component profile (after the manager's own).
  std::vector<std::pair<std::string, std::string>> properties;
  // false: the objects its service ports provide exist only while it is Active, as OpenRTM-aist's
  // CorbaPort makes them (calls meanwhile get OBJECT_NOT_EXIST). Component::serve_while_inactive.
  bool serve_while_inactive = true;
};

class Manager {
 public:
  Manager(Orb& orb, NamingClient& naming, ManagerOptions options);  // options.host "" -> gethostname()
  ~Manager();                                                       // shutdown()

  void add_factory(const std::string& type, ComponentFactory factory);

  // Creates, initializes, binds, starts (and activates if asked) one component; returns it.
  // Throws urs::util::ConfigError (unknown type, bad config) or std::runtime_error (naming,
  // initialization failure) with the reason; nothing is left bound on failure.
  Component& create(const ComponentSpec& spec);
  // The same with a factory of the caller's instead of the catalog's (spec.type names the type).
  Component& create(const ComponentSpec& spec, const ComponentFactory& factory);

  // Exits one component created here (its binding is removed if still its own) and destroys it.
  // False if the manager does not hold it.
  bool destroy(Component& component);

  // Exits every component and removes its binding. Idempotent.
  void shutdown();

  std::string naming_path(const Component& component) const;

 private:
  struct Hosted {
    std::unique_ptr<Component> component;
    std::string path;
  };
  std::string bind_unique(const ComponentSpec& spec, CORBA::Object_ptr object);  // returns instance name
  void release(Hosted& hosted);                                                  // unbinds if still ours

  Orb& orb_;
  NamingClient& naming_;
  ManagerOptions options_;
  std::map<std::string, ComponentFactory> factories_;
  mutable std::mutex mutex_;
  std::vector<Hosted> hosted_;
};

// The manager's configuration file:
//   rate: 100                    # default execution-context rate, Hz
//   plugins: [calculator]        # optional; agent plug-ins whose agents become component types
//   plugin_path: [/opt/plugins]  # optional; folders searched before URS_PLUGIN_PATH (docs/sdk.md)
//   components:
//     - type: Diagnostic         # a type in the manager's catalog
//       instance: Diagnostic7    # optional
//       rate: 50                 # optional
//       activate: true           # optional, default false
//       serve_while_inactive: false  # optional, default true (ComponentSpec::serve_while_inactive)
//       config: {...}            # optional, handed to the factory
// Throws urs::util::ConfigError naming the file, key and value of the first error.
struct ManagerConfig {
  double rate_hz = 100.0;
  std::vector<std::string> plugins;      // as written: a path (with a '/') or a name to search
  std::vector<std::string> plugin_path;  // existing folders
  std::vector<ComponentSpec> components;
};
ManagerConfig load_manager_config(const std::string& path);

}  // namespace urs::rtc
