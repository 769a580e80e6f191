// urs-rtc-manager: hosts the RT-Components listed in its configuration, runs their execution
// contexts and binds them in the naming service under "<host>.host_cxt/<Instance>.rtc".
// See docs/rtc.md.
//
// Exit codes: 0 clean shutdown (SIGINT/SIGTERM); 2 bad arguments or configuration; 1 a component
// could not be created or bound (the reason on stderr).

#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <fstream>

#include "components.hpp"
#include "urs/agent/plugin.hpp"
#include "urs/corba_agent/agent_component.hpp"
#include "urs/devices/catalog.hpp"
#include "urs/rtc/manager.hpp"
#include "urs/rtc/naming.hpp"
#include "urs/rtc/orb.hpp"
#include "urs/util/cli.hpp"
#include "urs/util/yaml_config.hpp"

namespace {

// Component types this binary can create. Registered here, explicitly, rather than by static
// self-registration (which a linker may silently drop).
std::set<std::string> add_catalog(urs::rtc::Manager& manager) {
  using namespace urs::rtc_manager;
  std::set<std::string> types = {"Diagnostic", "DiagnosticCaller", "Counter", "Sink", "Connector"};
  manager.add_factory("Diagnostic", make_diagnostic);
  manager.add_factory("DiagnosticCaller", make_diagnostic_caller);
  manager.add_factory("Counter", make_counter);
  manager.add_factory("Sink", make_sink);
  manager.add_factory("Connector", make_connector);
  for (const auto& [name, device] : urs::devices::catalog()) {
    manager.add_factory(device.component_type,
                        urs::corba_agent::agent_component_factory(device.component_type, device.make));
    types.insert(device.component_type);
  }
  return types;
}

// Each agent of the plug-ins becomes a component type, hosted generically as the devices are.
// Returns the paths of the plug-ins refused.
std::vector<std::string> add_plugins(urs::rtc::Manager& manager, const urs::rtc::ManagerConfig& config,
                                     std::set<std::string>& types) {
  if (config.plugins.empty()) return {};
  auto plugins = urs::agent::load_plugins(config.plugins, urs::agent::plugin_search_path(config.plugin_path), types);
  for (auto& loaded : plugins.agents) {
    const std::string type = loaded.agent.component_type;
    manager.add_factory(type, urs::corba_agent::agent_component_factory(type, std::move(loaded.agent.make)));
    types.insert(type);
  }
  std::vector<std::string> refused;
  for (const auto& refusal : plugins.refusals) refused.push_back(refusal.path);
  return refused;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"urs-rtc-manager: hosts RT-Components and binds them in the naming service"};
  std::string space;
  std::string naming = "127.0.0.1:2809";
  std::string config_path;
  std::string host;
  std::string listen;
  std::string ready_file;
  int call_timeout_ms = 10000;
  std::string log_level = "info";
  app.add_option("--space", space, "Name of the space the components belong to")->required();
  app.add_option("--naming", naming, "Naming service HOST:PORT (omniNames)")->capture_default_str();
  app.add_option("--config", config_path, "YAML file listing the components to create")->required();
  app.add_option("--host,--host-context", host,
                 "Naming context <host>.host_cxt (env URS_HOST_CONTEXT; default: this machine's host name)")
      ->envname("URS_HOST_CONTEXT");
  app.add_option("--listen", listen,
                 "HOST:PORT for the components' object references (default: an ephemeral port on this host's "
                 "address towards the naming service)");
  app.add_option("--call-timeout-ms", call_timeout_ms, "Bound on every outgoing CORBA call")->capture_default_str();
  app.add_option("--ready-file", ready_file, "Written with the bound naming paths once all components are up");
  app.add_option("--log-level", log_level, urs::util::kLogLevels)->capture_default_str();
  CLI11_PARSE(app, argc, argv);

  urs::util::block_shutdown_signals();
  urs::rtc::ManagerConfig config;
  urs::rtc::OrbOptions orb_options;
  try {
    urs::util::init_logging("urs-rtc-manager", log_level);
    orb_options.endpoint = listen.empty() ? urs::rtc::endpoint_towards(naming, "--naming")
                                          : urs::rtc::endpoint_from_address(listen, "--listen");
    if (call_timeout_ms < 0) throw urs::util::ConfigError("--call-timeout-ms: must be >= 0");
    orb_options.call_timeout = std::chrono::milliseconds(call_timeout_ms);
    config = urs::rtc::load_manager_config(config_path);
  } catch (const std::exception& e) {
    fmt::print(stderr, "urs-rtc-manager: {}\n", e.what());
    return 2;
  }

  urs::rtc::Orb orb(orb_options);
  urs::rtc::NamingClient naming_client(orb, naming);
  urs::rtc::Manager manager(orb, naming_client, {space, host, config.rate_hz});
  auto types = add_catalog(manager);
  const auto refused = add_plugins(manager, config, types);
  std::string bound;
  std::size_t created = 0;
  for (const auto& spec : config.components) {
    if (!refused.empty() && types.count(spec.type) == 0) {
      spdlog::error("{}: component type '{}' unknown (known: {}); not created (refused plug-in(s): {})", config_path,
                    spec.type, urs::util::join(types), urs::util::join({refused.begin(), refused.end()}));
      continue;
    }
    try {
      auto& component = manager.create(spec);
      bound += manager.naming_path(component) + "\n";
      ++created;
    } catch (const urs::util::ConfigError& e) {
      fmt::print(stderr, "urs-rtc-manager: {}: {}\n", config_path, e.what());
      return 2;
    } catch (const std::exception& e) {
      fmt::print(stderr, "urs-rtc-manager: {}\n", e.what());
      return 1;
    }
  }
  if (!ready_file.empty()) urs::util::write_file_atomically(ready_file, bound);
  spdlog::info("space {}: {} component(s) bound in naming service {}", space, created, naming);

  const int signal_number = urs::util::wait_for_shutdown();
  spdlog::info("signal {}: exiting components and removing their bindings", signal_number);
  manager.shutdown();
  return 0;
}
