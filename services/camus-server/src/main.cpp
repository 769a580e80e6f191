// urs-camus-server: see docs/camus.md.
//
// Wiring only: parse the command line, raise the descriptor limit, build the components in
// dependency order, serve until SIGINT/SIGTERM (re-reading the credentials and certificates on
// SIGHUP, on a thread of their own), then stop them in reverse order (transport first, so nothing
// new arrives).

#include <spdlog/spdlog.h>

#include <atomic>
#include <filesystem>
#include <iostream>
#include <memory>

#include "container.hpp"
#include "server_metrics.hpp"
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
#include "urs/metrics/flags.hpp"
#include "urs/planet/server.hpp"
#include "urs/util/cli.hpp"
#include "urs/util/heap.hpp"
#include "urs/util/reload.hpp"
#include "urs/util/service_manager.hpp"

namespace cs = urs::camus_server;

namespace {

constexpr const char* kProgram = "urs-camus-server";
constexpr unsigned kContainerWorkers = 4;
// How often the heap's free pages go back to the system: after a burst (a flood refused, many
// subscriptions dropped) the memory it took is returned within this time.
constexpr std::chrono::seconds kHeapTrimPeriod{10};

std::string db_path(const cs::ServerConfig& config, const char* name) {
  if (config.data_dir.empty()) return {};  // in memory
  return (std::filesystem::path(config.data_dir) / name).string();
}

cs::EventBusOptions bus_options(const cs::ServerConfig& config) {
  cs::EventBusOptions options;
  options.retention = config.event_retention;
  options.event_queue = config.limits.event_queue;
  options.event_queue_per_credential = config.limits.event_queue_per_credential;
  options.event_queue_per_session = config.limits.event_queue_per_session;
  options.event_queue_bytes = config.limits.event_queue_bytes;
  options.event_queue_bytes_per_credential = config.limits.event_queue_bytes_per_credential;
  options.topics = cs::TopicLimits{config.limits.max_topic_bytes, config.limits.max_topic_levels};
  options.max_subscriptions_per_session = config.limits.max_subscriptions_per_session;
  options.max_subscriptions_per_credential = config.limits.max_subscriptions_per_credential;
  options.max_subscriptions = config.limits.max_subscriptions;
  options.reserved_percent = static_cast<unsigned>(config.limits.reserved_percent);
  return options;
}

cs::RouterOptions router_options(const cs::ServerConfig& config, urs::metrics::Metrics* metrics) {
  cs::RouterOptions options;
  if (metrics != nullptr) options.calls = &metrics->served_calls("planet");
  options.space = config.space;
  options.default_deadline = std::chrono::milliseconds(config.default_deadline_ms);
  options.max_deadline_ms = config.limits.max_deadline_ms;
  options.max_pending_calls = config.limits.max_pending_calls;
  options.max_pending_calls_per_credential = config.limits.max_pending_calls_per_credential;
  options.max_pending_calls_per_session = config.limits.max_pending_calls_per_session;
  options.reserved_percent = static_cast<unsigned>(config.limits.reserved_percent);
  return options;
}

// Owns every component; members are declared in dependency order so that destruction (reverse
// order) never leaves a component pointing at a destroyed one. stop() orders the shutdown.
class CamusServer {
 public:
  // With `metrics` (which outlives it), the server counts its calls and reports its components.
  CamusServer(const cs::ServerConfig& config, std::shared_ptr<const urs::planet::Authenticator> authenticator,
              urs::metrics::Metrics* metrics)
      : bus_(db_path(config, "events.db"), bus_options(config), clock_),
        sink_(bus_),
        registry_(config.space, sink_),
        context_(db_path(config, "context.db"), sink_, clock_, timers_),
        host_(kContainerWorkers, sink_),
        registry_service_(registry_),
        container_(host_, config.space),
        builtins_(registry_service_, container_),
        router_(router_options(config, metrics), registry_, builtins_, timers_),
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
    options.max_message_bytes = config.limits.max_message_bytes;
    options.max_reassembly_bytes = config.limits.max_reassembly_bytes;  // ranges: checked by planet::Server
    options.max_send_queue_bytes = config.limits.max_send_queue_bytes;
    options.max_buffered_bytes = config.limits.max_buffered_bytes;
    options.max_buffered_bytes_per_credential = config.limits.max_buffered_bytes_per_credential;
    options.tls = config.tls;
    options.allow_plaintext_tokens = config.allow_plaintext_tokens;
    options.max_connections = config.limits.max_connections;
    options.max_connections_per_address = config.limits.max_connections_per_address;
    options.max_sessions_per_credential = config.limits.max_sessions_per_credential;
    options.max_resumable_sessions = config.limits.max_resumable_sessions;
    options.max_resumable_sessions_per_credential = config.limits.max_resumable_sessions_per_credential;
    options.reserved_percent = static_cast<unsigned>(config.limits.reserved_percent);
    server_ = std::make_unique<urs::planet::Server>(options, handler_);
    server_->start();
    if (metrics != nullptr) cs::add_server_metrics(*metrics, *server_, router_, registry_, bus_);
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

// SIGHUP: the TLS files and the credentials, each kept as it was when the new one cannot be
// loaded. Never throws.
void reload(CamusServer& server, const cs::ServerConfig& config) {
  if (config.tls.enabled) {
    try {
      server.reload_tls(config.tls);
      spdlog::info("SIGHUP: TLS certificate, key and client CAs re-read (for new connections)");
    } catch (const std::exception& e) {
      spdlog::error("SIGHUP: TLS files not reloaded, the previous ones stay in force: {}", e.what());
    }
  }
  if (!config.credentials.any()) {
    spdlog::info("SIGHUP: no --credentials or --token-file to re-read");
    return;
  }
  try {
    auto reloaded = cs::load_credentials(config.credentials);
    const size_t closed = server.set_authenticator(reloaded);
    spdlog::info("SIGHUP: {} credential(s) loaded; {} session(s) closed for a changed or revoked credential",
                 reloaded->all().size(), closed);
  } catch (const std::exception& e) {
    spdlog::error("SIGHUP: credentials not reloaded, the previous ones stay in force: {}", e.what());
  }
}

}  // namespace

int main(int argc, char** argv) {
  urs::util::block_shutdown_signals(/*with_reload=*/true);  // before any thread starts: all inherit it
  urs::util::use_few_arenas();
  const uint64_t descriptors = urs::util::raise_descriptor_limit();
  std::optional<cs::ServerConfig> config;
  try {
    config = cs::parse_command_line(argc, argv, std::cout);
    if (!config) return 0;  // --help
    urs::util::init_logging({kProgram, config->log_level, config->log_format, config->space});
  } catch (const urs::util::ConfigError& e) {
    std::cerr << kProgram << ": " << e.what() << "\n";
    return 2;
  }

  try {
    auto metrics = urs::metrics::metrics_for(config->metrics_listen, kProgram, config->space);
    auto credentials = cs::load_credentials(config->credentials);
    CamusServer server(*config, credentials, metrics.get());
    // Declared after the server, the endpoint (which reads it) is stopped before it goes.
    std::atomic<bool> listening{true};
    if (metrics) {
      metrics->health().add("listening", [&listening] {
        return listening ? std::string() : std::string("not listening: shutting down");
      });
    }
    auto endpoint = urs::metrics::serve(config->metrics_listen, metrics.get());
    urs::util::HeapTrimmer trimmer(kHeapTrimPeriod);
    if (credentials) {
      spdlog::info("{} credential(s) loaded", credentials->all().size());
    } else {
      spdlog::warn("no --credentials or --token-file: every peer is admitted as '{}' with role operator",
                   urs::planet::kAnonymousIdentity);
    }
    const std::string bound = config->listen.host + ":" + std::to_string(server.port());
    if (!config->port_file.empty()) urs::util::write_file_atomically(config->port_file, std::to_string(server.port()));
    urs::util::notify_ready();  // systemd (Type=notify): listening
    spdlog::info("space '{}': listening on {}{} (file descriptor limit {}, raised to the hard limit)", config->space,
                 bound, config->data_dir.empty() ? " (no --data-dir: state is kept in memory only)" : "", descriptors);
    // SIGHUP re-reads on the reload thread; whatever a file is, it never stops the server nor
    // delays its shutdown (the files are read with util::read_regular_file).
    auto reloader = std::make_unique<urs::util::ReloadWorker>([&] { reload(server, *config); });
    int sig = urs::util::wait_for_shutdown([&] { reloader->request(); });
    spdlog::info("signal {} received: shutting down", sig);
    listening = false;
    reloader.reset();  // a reload in progress ends first (it cannot block); none starts after
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
