// urs-bridge: the bridge between an RT-Middleware space and a CAMUS space (the papers' RSCM /
// SAM-RTC), and between spaces over DDS. With a naming service it is an RT-Component, bound at
// "<host>.host_cxt/<instance>.rtc"; with a CAMUS server a SAM of it; see docs/bridge.md. Its sides
// are composed from the configuration (urs/bridge/sides.hpp); without --naming it starts no ORB.
//
// Exit codes: 0 clean shutdown (SIGINT/SIGTERM); 2 bad arguments, configuration or IDL; 1 the
// bridge RTC could not be created or bound (the reason on stderr).

#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <chrono>
#include <filesystem>

#include "bridge_metrics.hpp"
#include "urs/bridge/config.hpp"
#include "urs/bridge/core/bridge.hpp"
#include "urs/bridge/rt/rt_side.hpp"
#include "urs/bridge/sides.hpp"
#include "urs/metrics/flags.hpp"
#include "urs/planet/client_flags.hpp"
#include "urs/rtc/manager.hpp"
#include "urs/rtc/naming.hpp"
#include "urs/rtc/orb.hpp"
#include "urs/rtc/orb_flags.hpp"
#include "urs/schema/interface_catalog.hpp"
#include "urs/util/cli.hpp"
#include "urs/util/heap.hpp"
#include "urs/util/program_flags.hpp"
#include "urs/util/service_manager.hpp"
#include "urs/util/tls.hpp"

int main(int argc, char** argv) {
  // One arena per thread that allocates made the bridge's workers, ORB and DDS threads about
  // 18 MiB of its resident memory; its calls do not contend on malloc enough to need them. What
  // large calls and streams leave free goes back to the system within seconds
  // (docs/performance.md, "Bridge memory").
  urs::util::use_few_arenas();
  const urs::util::HeapTrimmer trimmer(std::chrono::seconds(5));
  CLI::App app{"urs-bridge: makes RT-Components and CAMUS services usable from each other"};
  urs::util::ProgramFlags program;
  urs::rtc::OrbFlags orb_flags;
  std::string server;
  std::string naming;
  std::string token_file;
  std::string ready_file;
  std::string data_dir;
  urs::util::add_program_flags(app, program, "Name of the space the bridge belongs to",
                               "YAML file saying what to bridge");
  app.add_option("--server", server, "CAMUS server HOST:PORT (none: a space without CAMUS)");
  app.add_option("--naming", naming, "Naming service HOST:PORT, omniNames (none: a space without RT side)");
  urs::rtc::add_orb_flags(app, orb_flags, "the bridge's", "Bound on CORBA calls other than bridged ones");
  app.add_option("--token-file", token_file,
                 "File holding the bridge's credential token (role sam; operator to import context)");
  app.add_option("--ready-file", ready_file, "Written with the bridge RTC's naming path once it is bound");
  app.add_option("--data-dir", data_dir,
                 "Directory keeping the connections of the bridge's RTCs, restored after a restart (default: none)");
  urs::util::TlsConfig tls;
  urs::util::add_tls_client_flags(app, tls);
  std::string metrics_listen;
  urs::metrics::add_metrics_flag(app, metrics_listen);
  CLI11_PARSE(app, argc, argv);

  urs::util::block_shutdown_signals();
  urs::bridge::BridgeConfig config;
  std::optional<urs::planet::ClientOptions> planet;
  urs::rtc::OrbOptions orb_options;
  std::unique_ptr<urs::schema::InterfaceCatalog> catalog;
  std::unique_ptr<urs::metrics::Metrics> metrics;
  try {
    urs::util::init_logging(program.log_options("urs-bridge"));
    metrics = urs::metrics::metrics_for(metrics_listen, "urs-bridge", program.space);
    if (server.empty() && naming.empty()) throw urs::util::ConfigError("give --server, --naming or both");
    if (!server.empty()) planet = urs::planet::client_options_from(server, token_file, tls);
    if (planet && metrics) {  // the calls the CAMUS side makes and serves, as a SAM's
      planet->calls = &metrics->client_calls("planet");
      planet->served_calls = &metrics->served_calls("planet");
    }
    orb_options = urs::rtc::orb_options_from(orb_flags, naming);
    config = urs::bridge::load_bridge_config(program.config_path,
                                             orb_flags.host.empty() ? urs::util::host_name() : orb_flags.host);
    config.space = program.space;
    if (!data_dir.empty()) {
      std::error_code error;
      std::filesystem::create_directories(data_dir, error);
      if (error || !std::filesystem::is_directory(data_dir)) {
        throw urs::util::ConfigError("--data-dir: '" + data_dir +
                                     "' cannot be created: " + (error ? error.message() : "not a directory"));
      }
      config.data_dir = data_dir;
    }
    catalog = std::make_unique<urs::schema::InterfaceCatalog>();
    for (const auto& idl : config.idl) {
      for (const auto& loaded : catalog->load_idl(idl, config.include_dirs)) {
        spdlog::info("interface {} loaded from {}", loaded, idl);
      }
    }
  } catch (const std::exception& e) {
    fmt::print(stderr, "urs-bridge: {}\n", e.what());
    return 2;
  }

  // The RT side only with a naming service: a space without one starts no ORB.
  std::unique_ptr<urs::rtc::Orb> orb;
  std::unique_ptr<urs::rtc::NamingClient> naming_client;
  std::unique_ptr<urs::rtc::Manager> manager;
  if (!naming.empty()) {
    orb = std::make_unique<urs::rtc::Orb>(orb_options);
    naming_client = std::make_unique<urs::rtc::NamingClient>(*orb, naming);
    manager = std::make_unique<urs::rtc::Manager>(*orb, *naming_client,
                                                  urs::rtc::ManagerOptions{program.space, orb_flags.host, 10.0});
  }
  std::unique_ptr<urs::bridge::BridgeMetrics> bridge_metrics;
  if (metrics) bridge_metrics = std::make_unique<urs::bridge::BridgeMetrics>(*metrics);
  std::unique_ptr<urs::bridge::core::Bridge> bridge;
  try {
    urs::bridge::Composition composition = urs::bridge::compose(
        config, urs::bridge::SideResources{*catalog, orb.get(), naming_client.get(), manager.get(), planet});
    urs::bridge::core::Bridge::CallRecorders recorders;
    if (bridge_metrics) {
      recorders = [&](const urs::bridge::core::DirectionConfig& direction) {
        return bridge_metrics->direction(direction);
      };
    }
    bridge = std::make_unique<urs::bridge::core::Bridge>(config.name, std::move(composition.sides),
                                                         std::move(composition.layout), recorders);
  } catch (const urs::util::ConfigError& e) {
    fmt::print(stderr, "urs-bridge: {}: {}\n", program.config_path, e.what());
    return 2;
  }
  std::unique_ptr<urs::metrics::HttpEndpoint> endpoint;  // declared after what it reads: stopped first
  if (metrics) {
    if (auto* dds = dynamic_cast<urs::bridge::DdsSide*>(bridge->side("dds"))) {
      dds->record_served(&metrics->served_calls("dds"));
    }
    bridge_metrics->watch(*bridge);
  }
  try {
    endpoint = urs::metrics::serve(metrics_listen, metrics.get());
  } catch (const std::exception& e) {
    fmt::print(stderr, "urs-bridge: {}\n", e.what());
    return 2;
  }
  try {
    bridge->start();
    const auto* rt = dynamic_cast<const urs::bridge::RtSide*>(bridge->side("rt"));
    const std::string where = rt ? rt->path() : "(no naming service)";
    if (!ready_file.empty()) urs::util::write_file_atomically(ready_file, where + "\n");
    urs::util::notify_ready();  // systemd (Type=notify): the bridge RTC bound, the sides started
    spdlog::info("bridge {} at {} (space {}, CAMUS server {}, naming service {})", config.name, where, program.space,
                 server.empty() ? "none" : server, naming.empty() ? "none" : naming);
  } catch (const std::exception& e) {
    fmt::print(stderr, "urs-bridge: {}\n", e.what());
    return 1;
  }

  const int signal_number = urs::util::wait_for_shutdown();
  spdlog::info("signal {}: withdrawing everything bridged", signal_number);
  endpoint.reset();
  bridge->shutdown();
  if (manager) manager->shutdown();
  return 0;
}
