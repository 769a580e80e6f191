// urs-camus-server: see docs/camus.md.
//
// Wiring only: parse the command line, build the components in dependency order, serve until
// SIGINT/SIGTERM (re-reading the credentials on SIGHUP), then stop them in reverse order
// (transport first, so nothing new arrives).

#include <spdlog/spdlog.h>

#include <filesystem>
#include <iostream>
#include <memory>

#include "container.hpp"
#include "urs/agent/agent.hpp"
#include "urs/camus_server/config.hpp"
#include "urs/camus_server/context_store.hpp"
#include "urs/camus_server/credentials_file.hpp"
#include "urs/camus_server/event_bus.hpp"
#include "urs/camus_server/registry.hpp"
#include "urs/camus_server/router.hpp"
#include "urs/camus_server/session_handler.hpp"
#include "urs/camus_server/task_manager.hpp"
#include "urs/camus_server/tasks_agent.hpp"
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

cs::EventBusOptions bus_options(const cs::ServerConfig& config) {
  cs::EventBusOptions options;
  options.retention = config.event_retention;
  options.event_queue = config.limits.event_queue;
  options.event_queue_per_session = config.limits.event_queue_per_session;
  options.event_queue_bytes = config.limits.event_queue_bytes;
  options.topics = cs::TopicLimits{config.limits.max_topic_bytes, config.limits.max_topic_levels};
  options.max_subscriptions_per_session = config.limits.max_subscriptions_per_session;
  options.max_subscriptions = config.limits.max_subscriptions;
  return options;
}

cs::RouterOptions router_options(const cs::ServerConfig& config) {
  cs::RouterOptions options;
  options.space = config.space;
  options.default_deadline = std::chrono::milliseconds(config.default_deadline_ms);
  options.max_deadline_ms = config.limits.max_deadline_ms;
  options.max_pending_calls = config.limits.max_pending_calls;
  options.max_pending_calls_per_session = config.limits.max_pending_calls_per_session;
  return options;
}

// Owns every component; members are declared in dependency order so that destruction (reverse
// order) never leaves a component pointing at a destroyed one. stop() orders the shutdown.
class CamusServer {
 public:
  CamusServer(const cs::ServerConfig& config, std::shared_ptr<const urs::planet::Authenticator> authenticator)
      : bus_(db_path(config, "events.db"), bus_options(config), clock_),
        sink_(bus_),
        registry_(config.space, sink_),
        context_(db_path(config, "context.db"), sink_, clock_, timers_),
        host_(kContainerWorkers, sink_),
        registry_service_(registry_),
        container_(host_, config.space),
        builtins_(registry_service_, container_),
        router_(router_options(config), registry_, builtins_, timers_),
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
    options.authenticator = std::move(authenticator);
    options.heartbeat_interval = std::chrono::milliseconds(config.heartbeat_ms);
    options.heartbeat_timeout = std::chrono::milliseconds(config.heartbeat_timeout_ms);
    options.max_hello_bytes = static_cast<uint32_t>(config.limits.max_hello_bytes);
    options.max_reassembly_bytes = config.limits.max_reassembly_bytes;  // ranges: checked by planet::Server
    options.max_buffered_bytes = config.limits.max_buffered_bytes;
    options.tls = config.tls;
    options.allow_plaintext_tokens = config.allow_plaintext_tokens;
    options.max_connections = config.limits.max_connections;
    options.max_connections_per_address = config.limits.max_connections_per_address;
    server_ = std::make_unique<urs::planet::Server>(options, handler_);
    server_->start();
  }

  ~CamusServer() { stop(); }

  uint16_t port() const { return server_->port(); }

  // New credentials for the handshakes to come; returns the sessions closed because theirs changed.
  size_t set_authenticator(std::shared_ptr<const urs::planet::Authenticator> authenticator) {
    return server_->set_authenticator(std::move(authenticator));
  }

  void reload_tls(const urs::util::TlsConfig& tls) { server_->reload_tls(tls); }

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
  urs::util::block_shutdown_signals(/*with_reload=*/true);  // before any thread starts: all inherit it
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
    auto credentials = cs::load_credentials(config->credentials);
    CamusServer server(*config, credentials);
    if (credentials) {
      spdlog::info("{} credential(s) loaded", credentials->all().size());
    } else {
      spdlog::warn("no --credentials or --token-file: every peer is admitted as '{}' with role operator",
                   urs::planet::kAnonymousIdentity);
    }
    const std::string bound = config->listen.host + ":" + std::to_string(server.port());
    if (!config->port_file.empty()) urs::util::write_file_atomically(config->port_file, std::to_string(server.port()));
    spdlog::info("space '{}': listening on {}{}", config->space, bound,
                 config->data_dir.empty() ? " (no --data-dir: state is kept in memory only)" : "");
    int sig = urs::util::wait_for_shutdown([&] {
      if (config->tls.enabled) {
        try {
          server.reload_tls(config->tls);
          spdlog::info("SIGHUP: TLS certificate, key and client CAs re-read (for new connections)");
        } catch (const std::exception& e) {
          spdlog::error("SIGHUP: TLS files not reloaded, the previous ones stay in force: {}", e.what());
        }
      }
      if (!config->credentials.any()) {
        spdlog::info("SIGHUP: no --credentials or --token-file to re-read");
        return;
      }
      try {
        auto reloaded = cs::load_credentials(config->credentials);
        const size_t closed = server.set_authenticator(reloaded);
        spdlog::info("SIGHUP: {} credential(s) loaded; {} session(s) closed for a changed or revoked credential",
                     reloaded->all().size(), closed);
      } catch (const urs::util::ConfigError& e) {
        spdlog::error("SIGHUP: credentials not reloaded, the previous ones stay in force: {}", e.what());
      }
    });
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
