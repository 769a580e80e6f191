// urs-bridge: the bridge between an RT-Middleware space and a CAMUS space (the papers' RSCM /
// SAM-RTC). It is an RT-Component, bound at "<host>.host_cxt/<instance>.rtc", and a SAM of the
// CAMUS server; see docs/bridge.md.
//
// Exit codes: 0 clean shutdown (SIGINT/SIGTERM); 2 bad arguments, configuration or IDL; 1 the
// bridge RTC could not be created or bound (the reason on stderr).

#include <malloc.h>
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <cstdlib>
#include <filesystem>

#include "urs/bridge/bridge.hpp"
#include "urs/bridge/config.hpp"
#include "urs/bridge/interfaces.hpp"
#include "urs/rtc/manager.hpp"
#include "urs/rtc/naming.hpp"
#include "urs/rtc/orb.hpp"
#include "urs/util/cli.hpp"
#include "urs/util/tls.hpp"

int main(int argc, char** argv) {
  // glibc gives every thread that allocates an arena of its own, up to 8 per core; the bridge's
  // workers, ORB and DDS threads made them about 18 MiB of its resident memory. Its calls do not
  // contend on malloc enough to need them (docs/performance.md). MALLOC_ARENA_MAX still rules.
  if (std::getenv("MALLOC_ARENA_MAX") == nullptr) mallopt(M_ARENA_MAX, 2);
  CLI::App app{"urs-bridge: makes RT-Components and CAMUS services usable from each other"};
  std::string space;
  std::string server;
  std::string naming;
  std::string config_path;
  std::string host;
  std::string listen;
  std::string token_file;
  std::string ready_file;
  std::string data_dir;
  int call_timeout_ms = 10000;
  std::string log_level = "info";
  app.add_option("--space", space, "Name of the space the bridge belongs to")->required();
  app.add_option("--server", server, "CAMUS server HOST:PORT (none: a space without CAMUS)");
  app.add_option("--naming", naming, "Naming service HOST:PORT, omniNames (none: a space without RT side)");
  app.add_option("--config", config_path, "YAML file saying what to bridge")->required();
  app.add_option("--host,--host-context", host,
                 "Naming context <host>.host_cxt (env URS_HOST_CONTEXT; default: this machine's host name)")
      ->envname("URS_HOST_CONTEXT");
  app.add_option("--listen", listen,
                 "HOST:PORT for the bridge's object references (default: an ephemeral port on this host's "
                 "address towards the naming service)");
  app.add_option("--token-file", token_file,
                 "File holding the bridge's credential token (role sam; operator to import context)");
  app.add_option("--call-timeout-ms", call_timeout_ms, "Bound on CORBA calls other than bridged ones")
      ->capture_default_str();
  app.add_option("--ready-file", ready_file, "Written with the bridge RTC's naming path once it is bound");
  app.add_option("--data-dir", data_dir,
                 "Directory keeping the connections of the bridge's RTCs, restored after a restart (default: none)");
  app.add_option("--log-level", log_level, urs::util::kLogLevels)->capture_default_str();
  urs::util::TlsConfig tls;
  urs::util::add_tls_client_flags(app, tls);
  CLI11_PARSE(app, argc, argv);

  urs::util::block_shutdown_signals();
  urs::bridge::BridgeConfig config;
  std::optional<urs::planet::ClientOptions> planet;
  urs::rtc::OrbOptions orb_options;
  std::unique_ptr<urs::bridge::InterfaceCatalog> catalog;
  try {
    urs::util::init_logging("urs-bridge", log_level);
    if (server.empty() && naming.empty()) throw urs::util::ConfigError("give --server, --naming or both");
    if (!server.empty()) {
      const auto endpoint = urs::util::parse_endpoint(server, "--server");
      planet.emplace();
      planet->host = endpoint.host;
      planet->port = endpoint.port;
      planet->token = urs::util::read_token_file(token_file);
      urs::util::check_tls_client(tls);
      planet->tls = tls;
    }
    if (!listen.empty()) {
      orb_options.endpoint = urs::rtc::endpoint_from_address(listen, "--listen");
    } else if (!naming.empty()) {
      orb_options.endpoint = urs::rtc::endpoint_towards(naming, "--naming");
    }
    if (call_timeout_ms < 0) throw urs::util::ConfigError("--call-timeout-ms: must be >= 0");
    orb_options.call_timeout = std::chrono::milliseconds(call_timeout_ms);
    config = urs::bridge::load_bridge_config(config_path, host.empty() ? urs::util::host_name() : host);
    config.space = space;
    if (!data_dir.empty()) {
      std::error_code error;
      std::filesystem::create_directories(data_dir, error);
      if (error || !std::filesystem::is_directory(data_dir)) {
        throw urs::util::ConfigError("--data-dir: '" + data_dir + "' cannot be created: " +
                                     (error ? error.message() : "not a directory"));
      }
      config.data_dir = data_dir;
    }
    catalog = std::make_unique<urs::bridge::InterfaceCatalog>();
    for (const auto& idl : config.idl) {
      for (const auto& loaded : catalog->load_idl(idl, config.include_dirs)) {
        spdlog::info("interface {} loaded from {}", loaded, idl);
      }
    }
  } catch (const std::exception& e) {
    fmt::print(stderr, "urs-bridge: {}\n", e.what());
    return 2;
  }

  urs::rtc::Orb orb(orb_options);
  std::unique_ptr<urs::rtc::NamingClient> naming_client;
  std::unique_ptr<urs::rtc::Manager> manager;
  if (!naming.empty()) {
    naming_client = std::make_unique<urs::rtc::NamingClient>(orb, naming);
    manager = std::make_unique<urs::rtc::Manager>(orb, *naming_client, urs::rtc::ManagerOptions{space, host, 10.0});
  }
  std::unique_ptr<urs::bridge::Bridge> bridge;
  try {
    bridge = std::make_unique<urs::bridge::Bridge>(orb, naming_client.get(), manager.get(), *catalog, config, planet);
  } catch (const urs::util::ConfigError& e) {
    fmt::print(stderr, "urs-bridge: {}: {}\n", config_path, e.what());
    return 2;
  }
  try {
    auto* component = bridge->start();
    const std::string where = component ? manager->naming_path(*component) : "(no naming service)";
    if (!ready_file.empty()) urs::util::write_file_atomically(ready_file, where + "\n");
    spdlog::info("bridge {} at {} (space {}, CAMUS server {}, naming service {})", config.name, where, space,
                 server.empty() ? "none" : server, naming.empty() ? "none" : naming);
  } catch (const std::exception& e) {
    fmt::print(stderr, "urs-bridge: {}\n", e.what());
    return 1;
  }

  const int signal_number = urs::util::wait_for_shutdown();
  spdlog::info("signal {}: withdrawing everything bridged", signal_number);
  bridge->shutdown();
  if (manager) manager->shutdown();
  return 0;
}
