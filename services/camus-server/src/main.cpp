// urs-camus-server: see docs/camus.md.
//
// Wiring only: parse the command line, build the components in dependency order, serve until
// SIGINT/SIGTERM, then stop them in reverse order (transport first, so nothing new arrives).

#include <spdlog/spdlog.h>

#include <filesystem>
#include <iostream>
#include <memory>

#include "container.hpp"
#include "urs/agent/agent.hpp"
#include "urs/camus_server/config.hpp"
#include "urs/camus_server/context_store.hpp"
#include "urs/camus_server/event_bus.hpp"
#include "urs/camus_server/registry.hpp"
#include "urs/camus_server/router.hpp"
#include "urs/camus_server/session_handler.hpp"
#include "urs/camus_server/task_manager.hpp"
#include "urs/camus_server/timer.hpp"
#include "urs/planet/server.hpp"
#include "urs/util/cli.hpp"

namespace cs = urs::camus_server;

namespace {

constexpr const char* kProgram = "urs-camus-server";
constexpr unsigned kContainerWorkers = 4;

std::string db_path(const cs::ServerConfig& config, const char* name) {
  if (config.data_dir.empty()) return {};  // in memory
  return (std::filesystem::path(config.data_dir) / name).string();
}

// Owns every component; members are declared in dependency order so that destruction (reverse
// order) never leaves a component pointing at a destroyed one. stop() orders the shutdown.
class CamusServer {
 public:
  explicit CamusServer(const cs::ServerConfig& config)
      : bus_(db_path(config, "events.db"), cs::EventBusOptions{config.event_retention, 100000, 65536}, clock_),
        sink_(bus_),
        registry_(config.space, sink_),
        context_(db_path(config, "context.db"), sink_, clock_, timers_),
        host_(kContainerWorkers, sink_),
        registry_service_(registry_),
        container_(host_),
        builtins_(registry_service_, container_),
        router_(cs::RouterOptions{config.space, std::chrono::milliseconds(config.default_deadline_ms)}, registry_,
                builtins_, timers_),
        invoker_(router_),
        tasks_(db_path(config, "tasks.db"), cs::TaskManagerOptions{config.tasks_dir, 64, 1000}, invoker_, bus_,
               context_, registry_, sink_, clock_),
        handler_(registry_, router_, bus_) {
    const auto* file = urs::camus::ServiceInfo::descriptor()->file();
    registry_.add_builtin(cs::RegistryService::kName, *file->FindServiceByName("Registry"));
    registry_.add_builtin(cs::ContextAgent::kName, *file->FindServiceByName("Context"));
    registry_.add_builtin(cs::TasksAgent::kName, *file->FindServiceByName("Tasks"));
    host_.add({cs::ContextAgent::kName, std::make_shared<cs::ContextAgent>(context_), {}, 0});
    host_.add({cs::TasksAgent::kName, std::make_shared<cs::TasksAgent>(tasks_), {}, 0});
    host_.start();
    tasks_.start();

    urs::planet::ServerOptions options;
    options.host = config.listen.host;
    options.port = config.listen.port;
    options.space = config.space;
    options.token = config.token;
    options.heartbeat_interval = std::chrono::milliseconds(config.heartbeat_ms);
    options.heartbeat_timeout = std::chrono::milliseconds(config.heartbeat_timeout_ms);
    server_ = std::make_unique<urs::planet::Server>(options, handler_);
    server_->start();
  }

  ~CamusServer() { stop(); }

  uint16_t port() const { return server_->port(); }

  void stop() {
    if (server_) server_->stop();  // closes every session: on_close cleans up behind them
    tasks_.stop();                 // runs stay "running" in the store and resume at the next start
    host_.stop();                  // queued built-in calls are answered UNAVAILABLE
    router_.shutdown();            // whatever is still pending is answered UNAVAILABLE
    bus_.stop();                   // stores what is queued
    timers_.stop();
  }

 private:
  cs::SystemClock clock_;
  cs::TimerThread timers_;
  cs::EventBus bus_;
  cs::BusEventSink sink_;
  cs::Registry registry_;
  cs::ContextStore context_;
  urs::agent::AgentHost host_;
  cs::RegistryService registry_service_;
  cs::AgentHostContainer container_;
  cs::BuiltinServices builtins_;
  cs::Router router_;
  cs::RouterInvoker invoker_;
  cs::TaskManager tasks_;
  cs::CamusSessionHandler handler_;
  std::unique_ptr<urs::planet::Server> server_;
};

}  // namespace

int main(int argc, char** argv) {
  urs::util::block_shutdown_signals();  // before any thread starts, so every thread inherits it
  std::optional<cs::ServerConfig> config;
  try {
    config = cs::parse_command_line(argc, argv, std::cout);
    if (!config) return 0;  // --help
    urs::util::init_logging(kProgram, config->log_level);
  } catch (const urs::util::ConfigError& e) {
    std::cerr << kProgram << ": " << e.what() << "\n";
    return 2;
  }

  try {
    CamusServer server(*config);
    const std::string bound = config->listen.host + ":" + std::to_string(server.port());
    if (!config->port_file.empty()) urs::util::write_file_atomically(config->port_file, std::to_string(server.port()));
    spdlog::info("space '{}': listening on {}{}", config->space, bound,
                 config->data_dir.empty() ? " (no --data-dir: state is kept in memory only)" : "");
    int sig = urs::util::wait_for_shutdown();
    spdlog::info("signal {} received: shutting down", sig);
    server.stop();
    spdlog::info("stopped");
  } catch (const urs::util::ConfigError& e) {
    // Bad content behind a flag, e.g. a task file in --tasks-dir.
    std::cerr << kProgram << ": " << e.what() << "\n";
    return 2;
  } catch (const std::exception& e) {
    // Start-up failures: a port in use, an unreadable database.
    std::cerr << kProgram << ": " << e.what() << "\n";
    return 1;
  }
  return 0;
}
