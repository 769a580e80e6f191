// urs-rtc-manager: hosts the RT-Components listed in its configuration, runs their execution
// contexts and binds them in the naming service under "<host>.host_cxt/<Instance>.rtc".
// See docs/rtc.md.
//
// Exit codes: 0 clean shutdown (SIGINT/SIGTERM); 2 bad arguments or configuration; 1 a component
// could not be created or bound (the reason on stderr).

#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <atomic>
#include <fstream>

#include "components.hpp"
#include "urs/agent/plugin.hpp"
#include "urs/corba_agent/agent_component.hpp"
#include "urs/devices/catalog.hpp"
#include "urs/metrics/flags.hpp"
#include "urs/rtc/manager.hpp"
#include "urs/rtc/naming.hpp"
#include "urs/rtc/orb.hpp"
#include "urs/rtc/orb_flags.hpp"
#include "urs/util/cli.hpp"
#include "urs/util/program_flags.hpp"
#include "urs/util/service_manager.hpp"
#include "urs/util/yaml_config.hpp"

namespace {

// Component types this binary can create. Registered here, explicitly, rather than by static
// self-registration (which a linker may silently drop).
// With `calls`, the calls of the components hosting an agent are counted there.
std::set<std::string> add_catalog(urs::rtc::Manager& manager, urs::call::CallRecorder* calls) {
  using namespace urs::rtc_manager;
  std::set<std::string> types = {"Diagnostic", "DiagnosticCaller", "Counter", "Sink", "Connector"};
  manager.add_factory("Diagnostic", diagnostic_factory(calls));
  manager.add_factory("DiagnosticCaller", make_diagnostic_caller);
  manager.add_factory("Counter", make_counter);
  manager.add_factory("Sink", make_sink);
  manager.add_factory("Connector", make_connector);
  for (const auto& [name, device] : urs::devices::catalog()) {
    manager.add_factory(device.component_type,
                        urs::corba_agent::agent_component_factory(device.component_type, device.make, calls));
    types.insert(device.component_type);
  }
  return types;
}

// Each agent of the plug-ins becomes a component type, hosted generically as the devices are.
// Returns the paths of the plug-ins refused.
std::vector<std::string> add_plugins(urs::rtc::Manager& manager, const urs::rtc::ManagerConfig& config,
                                     std::set<std::string>& types, urs::call::CallRecorder* calls) {
  if (config.plugins.empty()) return {};
  auto plugins = urs::agent::load_plugins(config.plugins, urs::agent::plugin_search_path(config.plugin_path), types);
  for (auto& loaded : plugins.agents) {
    const std::string type = loaded.agent.component_type;
    manager.add_factory(type, urs::corba_agent::agent_component_factory(type, std::move(loaded.agent.make), calls));
    types.insert(type);
  }
  std::vector<std::string> refused;
  for (const auto& refusal : plugins.refusals) refused.push_back(refusal.path);
  return refused;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"urs-rtc-manager: hosts RT-Components and binds them in the naming service"};
  urs::util::ProgramFlags program;
  urs::rtc::OrbFlags orb_flags;
  std::string naming = "127.0.0.1:2809";
  std::string ready_file;
  urs::util::add_program_flags(app, program, "Name of the space the components belong to",
                               "YAML file listing the components to create");
  app.add_option("--naming", naming, "Naming service HOST:PORT (omniNames)")->capture_default_str();
  urs::rtc::add_orb_flags(app, orb_flags, "the components'", "Bound on every outgoing CORBA call");
  app.add_option("--ready-file", ready_file, "Written with the bound naming paths once all components are up");
  std::string metrics_listen;
  urs::metrics::add_metrics_flag(app, metrics_listen);
  CLI11_PARSE(app, argc, argv);

  urs::util::block_shutdown_signals();
  urs::rtc::ManagerConfig config;
  urs::rtc::OrbOptions orb_options;
  std::unique_ptr<urs::metrics::Metrics> metrics;
  try {
    urs::util::init_logging(program.log_options("urs-rtc-manager"));
    metrics = urs::metrics::metrics_for(metrics_listen, "urs-rtc-manager", program.space);
    urs::util::parse_endpoint(naming, "--naming");  // a naming service is required here
    orb_options = urs::rtc::orb_options_from(orb_flags, naming);
    config = urs::rtc::load_manager_config(program.config_path);
  } catch (const std::exception& e) {
    fmt::print(stderr, "urs-rtc-manager: {}\n", e.what());
    return 2;
  }

  urs::rtc::Orb orb(orb_options);
  urs::rtc::NamingClient naming_client(orb, naming);
  urs::rtc::Manager manager(orb, naming_client, {program.space, orb_flags.host, config.rate_hz});
  urs::call::CallRecorder* calls = metrics ? &metrics->served_calls("corba") : nullptr;
  auto types = add_catalog(manager, calls);
  const auto refused = add_plugins(manager, config, types, calls);
  // Ready once every component is created and bound (the loop below); not while shutting down.
  std::atomic<int> bound_state{0};  // 0 binding, 1 bound, 2 shutting down
  if (metrics) {
    metrics->health().add("components bound", [&bound_state] {
      const int state = bound_state.load();
      return state == 1 ? std::string() : state == 0 ? std::string("binding components") : std::string("shutting down");
    });
  }
  std::unique_ptr<urs::metrics::HttpEndpoint> endpoint;  // declared after what it reads: stopped first
  try {
    endpoint = urs::metrics::serve(metrics_listen, metrics.get());
  } catch (const std::exception& e) {
    fmt::print(stderr, "urs-rtc-manager: {}\n", e.what());
    return 2;
  }
  std::string bound;
  std::size_t created = 0;
  for (const auto& spec : config.components) {
    if (!refused.empty() && types.count(spec.type) == 0) {
      spdlog::error("{}: component type '{}' unknown (known: {}); not created (refused plug-in(s): {})",
                    program.config_path, spec.type, urs::util::join(types),
                    urs::util::join({refused.begin(), refused.end()}));
      continue;
    }
    try {
      auto& component = manager.create(spec);
      bound += manager.naming_path(component) + "\n";
      ++created;
    } catch (const urs::util::ConfigError& e) {
      fmt::print(stderr, "urs-rtc-manager: {}: {}\n", program.config_path, e.what());
      return 2;
    } catch (const std::exception& e) {
      fmt::print(stderr, "urs-rtc-manager: {}\n", e.what());
      return 1;
    }
  }
  if (!ready_file.empty()) urs::util::write_file_atomically(ready_file, bound);
  bound_state = 1;
  urs::util::notify_ready();  // systemd (Type=notify): every component bound
  spdlog::info("space {}: {} component(s) bound in naming service {}", program.space, created, naming);

  const int signal_number = urs::util::wait_for_shutdown();
  spdlog::info("signal {}: exiting components and removing their bindings", signal_number);
  bound_state = 2;
  endpoint.reset();
  manager.shutdown();
  return 0;
}
