// urs-sam: a Service Agent Manager. Hosts the service agents listed in its config, registers them
// with the CAMUS server and keeps them registered across server restarts and network cuts.

#include <signal.h>
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <set>

#include "sam_config.hpp"
#include "urs/agent/agent.hpp"
#include "urs/agent/camus.hpp"
#include "urs/agent/client_sink.hpp"
#include "urs/agent/plugin.hpp"
#include "urs/devices/catalog.hpp"
#include "urs/diagnostic/diagnostic_agent.hpp"
#include "urs/metrics/flags.hpp"
#include "urs/planet/client.hpp"
#include "urs/planet/client_flags.hpp"
#include "urs/util/cli.hpp"
#include "urs/util/program_flags.hpp"
#include "urs/util/service_manager.hpp"
#include "urs/util/tls.hpp"

namespace {

using AgentFactory = std::function<std::shared_ptr<urs::agent::ServiceAgent>(const urs::sam::AgentConfig&)>;

// Agent types this binary can host. Registered here, explicitly, rather than by static
// self-registration (which a linker may silently drop). Plug-ins listed in the config add theirs.
std::map<std::string, AgentFactory> agent_catalog() {
  std::map<std::string, AgentFactory> catalog = {
      {"diagnostic", [](const urs::sam::AgentConfig&) { return std::make_shared<urs::diagnostic::DiagnosticAgent>(); }},
  };
  for (const auto& [name, device] : urs::devices::catalog()) {
    catalog[name] = [make = device.make](const urs::sam::AgentConfig& agent) { return make(agent.params); };
  }
  return catalog;
}

std::atomic<int> g_exit_code{0};

// Unregisters every hosted service and waits (at most 2 s) for the server to confirm: from then
// on it routes their calls to the other providers of each (replicas of this SAM), or answers
// UNKNOWN_SERVICE; the calls already here are still answered (host.stop() runs those started).
void leave_registry(urs::planet::Client& client, const urs::agent::AgentHost& host) {
  struct Left {
    std::mutex mutex;
    std::condition_variable done;
    size_t waiting = 0;
  };
  auto left = std::make_shared<Left>();
  const auto services = host.services();
  left->waiting = services.size();
  for (const auto& service : services) {
    client.unregister_service(service.name, [left, name = service.name](urs::planet::CallResult result) {
      if (!result.ok()) {
        spdlog::warn("unregistering service {}: {}: {}", name, urs::planet::status_name(result.status), result.message);
      }
      std::lock_guard<std::mutex> lock(left->mutex);
      --left->waiting;
      left->done.notify_all();
    });
  }
  std::unique_lock<std::mutex> lock(left->mutex);
  if (!left->done.wait_for(lock, std::chrono::seconds(2), [&] { return left->waiting == 0; })) {
    spdlog::warn("{} service(s) not confirmed unregistered within 2 s; stopping all the same", left->waiting);
  }
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"urs-sam: Service Agent Manager of a CAMUS space"};
  urs::util::ProgramFlags program;
  std::string server = "127.0.0.1:7600";
  std::string token_file;
  urs::util::add_program_flags(app, program, "Name of the space this SAM belongs to",
                               "YAML file listing the agents to host");
  app.add_option("--server", server, "CAMUS server HOST:PORT")->capture_default_str();
  app.add_option("--token-file", token_file,
                 "File holding this SAM's credential token (a credential of role sam or operator)");
  urs::util::TlsConfig tls;
  urs::util::add_tls_client_flags(app, tls);
  std::string metrics_listen;
  urs::metrics::add_metrics_flag(app, metrics_listen);
  CLI11_PARSE(app, argc, argv);

  urs::util::block_shutdown_signals();
  auto catalog = agent_catalog();
  urs::sam::SamConfig config;
  urs::planet::ClientOptions options;
  std::vector<urs::agent::HostedService> services;
  std::unique_ptr<urs::metrics::Metrics> metrics;
  try {
    urs::util::init_logging(program.log_options("urs-sam"));
    metrics = urs::metrics::metrics_for(metrics_listen, "urs-sam", program.space);
    options = urs::planet::client_options_from(server, token_file, tls);
    const auto& config_path = program.config_path;
    config =
        urs::sam::load_sam_config(config_path, urs::util::host_name(), [&catalog](const urs::sam::SamConfig& partial) {
          urs::sam::AgentTypes types;
          for (const auto& [type, factory] : catalog) types.known.insert(type);
          if (partial.plugins.empty()) return types;
          auto plugins = urs::agent::load_plugins(partial.plugins, urs::agent::plugin_search_path(partial.plugin_path),
                                                  types.known);
          for (auto& loaded : plugins.agents) {
            types.known.insert(loaded.agent.type);
            catalog[loaded.agent.type] = [make = std::move(loaded.agent.make)](const urs::sam::AgentConfig& agent) {
              return make(agent.params);
            };
          }
          for (const auto& refusal : plugins.refusals) types.refused.push_back(refusal.path);
          return types;
        });
    for (const auto& agent : config.agents) {
      try {
        services.push_back({agent.name, catalog.at(agent.type)(agent), agent.properties, agent.deadline_ms});
      } catch (const std::exception& e) {
        throw urs::util::ConfigError("--config '" + program.config_path + "': agent '" + agent.name + "' (type " +
                                     agent.type + "): " + e.what());
      }
    }
  } catch (const std::exception& e) {
    fmt::print(stderr, "urs-sam: {}\n", e.what());
    return 2;
  }
  options.peer_name = config.name;
  options.role = urs::planet::SAM;
  if (metrics) {
    options.calls = &metrics->client_calls("planet");
    options.served_calls = &metrics->served_calls("planet");
  }

  // Ready (systemd Type=notify) once every hosted service is registered: the set of those registered
  // so far, filled by the client's thread (declared before the client, which is stopped before they go);
  // a re-registration after a reconnect adds nothing.
  const size_t to_register = services.size();
  std::mutex registered_mutex;
  std::set<std::string> registered;
  urs::planet::Client client(options);
  urs::agent::ClientEventSink sink(client);
  urs::agent::AgentHost host(config.workers, sink);
  for (auto& service : services) host.add(std::move(service));

  urs::agent::serve_requests(client, host);
  client.on_connected([&space = program.space, &server](const urs::planet::Welcome& welcome) {
    if (welcome.space() != space) {
      spdlog::critical("server {} serves space '{}' but this SAM was started with --space {}; stopping", server,
                       welcome.space(), space);
      g_exit_code = 2;
      kill(getpid(), SIGTERM);
      return;
    }
    spdlog::info("connected to {} (space {}, server instance {})", server, welcome.space(), welcome.server_instance());
  });
  client.on_disconnected(
      [&server](const std::string& reason) { spdlog::warn("lost the server {}: {}; reconnecting", server, reason); });
  for (const auto& service : host.services()) {
    client.register_service(urs::agent::registration(service),
                            [&, name = service.name](urs::planet::CallResult result) {
                              if (result.ok()) {
                                spdlog::info("registered service {}", name);
                                std::lock_guard<std::mutex> lock(registered_mutex);
                                if (registered.insert(name).second && registered.size() == to_register)
                                  urs::util::notify_ready();
                              } else {
                                spdlog::error("registering service {} failed: {}: {}", name,
                                              urs::planet::status_name(result.status), result.message);
                              }
                            });
  }
  // Ready: connected, and every hosted service registered (they stay registered across reconnects).
  if (metrics) {
    metrics->health().add("agents registered", [&] {
      if (!client.connected()) return "not connected to " + server + ": " + client.last_error();
      std::lock_guard<std::mutex> lock(registered_mutex);
      if (registered.size() == to_register) return std::string();
      return std::to_string(registered.size()) + " of " + std::to_string(to_register) + " services registered";
    });
  }
  client.start();
  host.start();
  if (to_register == 0) urs::util::notify_ready();
  std::unique_ptr<urs::metrics::HttpEndpoint> endpoint;  // stopped before what it reads
  try {
    endpoint = urs::metrics::serve(metrics_listen, metrics.get());
  } catch (const std::exception& e) {
    fmt::print(stderr, "urs-sam: {}\n", e.what());
    host.stop();
    client.stop();
    return 2;
  }
  spdlog::info("{} hosting {} agent(s), server {}", config.name, config.agents.size(), server);

  int sig = urs::util::wait_for_shutdown();
  spdlog::info("signal {}: shutting down", sig);
  endpoint.reset();
  leave_registry(client, host);
  host.stop();
  client.stop();
  return g_exit_code.load();
}
