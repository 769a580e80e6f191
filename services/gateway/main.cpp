// urs-gateway: one space's live view and controls for people and tools (docs/dashboard.md). It
// attaches to its space (the CAMUS server, the naming service, the devices' DDS domain) and reads
// the DDS link between spaces, and serves on one port the dashboard (HTTP) and the Foxglove
// WebSocket protocol that Foxglove and Lichtblick open.
//
// Exit codes: 0 clean shutdown (SIGINT/SIGTERM); 2 bad arguments or configuration; 1 it cannot
// listen, or DDS or the ORB refuses to start (the reason on stderr).

#include <spdlog/spdlog.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <filesystem>
#include <memory>

#include "urs/federation/dds_security.hpp"
#include "urs/gateway/camus_source.hpp"
#include "urs/gateway/dds_source.hpp"
#include "urs/gateway/gateway.hpp"
#include "urs/gateway/hub.hpp"
#include "urs/gateway/logins.hpp"
#include "urs/gateway/playback.hpp"
#include "urs/gateway/rt_source.hpp"
#include "urs/gateway/server.hpp"
#include "urs/gateway/world_source.hpp"
#include "urs/metrics/flags.hpp"
#include "urs/rtc/orb.hpp"
#include "urs/util/cli.hpp"
#include "urs/util/heap.hpp"
#include "urs/util/program_flags.hpp"
#include "urs/util/service_manager.hpp"
#include "urs/util/tls.hpp"

namespace gw = urs::gateway;

namespace {

// The dashboard's files: next to the program in the build tree, or in the installed share folder.
std::string default_web_dir() {
  std::error_code error;
  const auto exe = std::filesystem::read_symlink("/proc/self/exe", error);
  if (error) return "web";
  const auto dir = exe.parent_path();
  for (const auto& candidate : {dir / "web", dir / ".." / "share" / "urslink" / "web"}) {
    if (std::filesystem::exists(candidate / "index.html")) return candidate.lexically_normal().string();
  }
  return (dir / "web").string();
}

std::vector<std::string> split(const std::string& list) {
  std::vector<std::string> out;
  std::string item;
  for (char c : list + ",") {
    if (c == ',') {
      if (!item.empty()) out.push_back(item);
      item.clear();
    } else if (c != ' ') {
      item += c;
    }
  }
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  urs::util::use_few_arenas();  // as urs-bridge
  CLI::App app{"urs-gateway: a space's dashboard and Foxglove WebSocket endpoint"};
  std::string space, server, naming, listen = "127.0.0.1:8765", token_file, viewer_token_file, web_dir,
                                     anonymous = "none", port_file, log_level = "info", robots,
                                     devices_source = "localizer";
  bool read_only = false, dds_udp_only = false, playback = false;
  int dds_domain = -1, devices_domain = -1, dds_lease_ms = 3000, rt_poll_ms = 1000, call_deadline_ms = 10000,
      max_clients = 64, max_queue_kib = 8192;
  std::vector<std::string> dds_peers, dds_servers, dds_tcp_connect, idl_files;
  std::string dds_pki;
  app.add_option("--space", space, "Name of the space the gateway shows and drives")->required()->envname("URS_SPACE");
  app.add_option("--server", server, "CAMUS server HOST:PORT (none: a space without CAMUS)")->envname("URS_SERVER");
  app.add_option("--naming", naming, "Naming service HOST:PORT (none: a space without RT side)")->envname("URS_NAMING");
  app.add_flag("--playback", playback,
               "Serve a recording that a player publishes (urs play): attached to no space; the --token-file "
               "credential logs in as the operator who may publish");
  app.add_option("--listen", listen, "HOST:PORT of the dashboard and the WebSocket endpoint")
      ->envname("URS_GATEWAY_LISTEN")
      ->capture_default_str();
  app.add_option("--token-file", token_file,
                 "The space's token: the gateway's own Planet session; without --server, the operators' credential")
      ->envname("URS_TOKEN_FILE");
  app.add_option("--viewer-token-file", viewer_token_file, "A credential that logs in as a viewer (sees, never acts)")
      ->envname("URS_VIEWER_TOKEN_FILE");
  app.add_flag("--read-only", read_only, "Every login is a viewer: nothing can be called through this gateway");
  app.add_option("--anonymous", anonymous, "Role of a connection without a login")
      ->check(CLI::IsMember({"none", "viewer", "operator"}))
      ->envname("URS_GATEWAY_ANONYMOUS")
      ->capture_default_str();
  app.add_option("--web-dir", web_dir, "The dashboard's files (default: next to the program, or share/urslink/web)");
  app.add_option("--dds-domain", dds_domain, "Read the DDS link between spaces in this domain (default: not at all)")
      ->check(CLI::Range(0, 232))
      ->envname("URS_DDS_DOMAIN");
  app.add_option("--dds-peer", dds_peers,
                 "Unicast DDS peer HOST or HOST:PORT (repeatable), for networks without multicast");
  app.add_option("--dds-discovery-server", dds_servers, "Fast DDS discovery server HOST:PORT (repeatable)");
  app.add_flag("--dds-udp-only", dds_udp_only, "No shared-memory transport (between containers)");
  app.add_option("--dds-tcp-connect", dds_tcp_connect,
                 "Read a link that runs over TCP (dds.transport: tcp): a listening bridge's HOST:PORT (repeatable)")
      ->excludes("--dds-peer")
      ->excludes("--dds-udp-only");
  app.add_option("--dds-pki", dds_pki,
                 "Join a link secured with DDS-Security: deploy/pki.sh's folder (ca.pem, governance.p7s, crl.pem) "
                 "holding this gateway's member folder urs-gateway.<space>")
      ->envname("URS_DDS_PKI");
  app.add_option("--dds-lease-ms", dds_lease_ms, "The link's lease, as the bridges' dds.lease_ms")
      ->check(CLI::Range(100, 600000))
      ->capture_default_str();
  app.add_option("--devices-domain", devices_domain, "The space's devices DDS domain: robot poses at full rate")
      ->check(CLI::Range(0, 232));
  app.add_option("--robots", robots, "Robots to follow in the devices' domain, comma-separated (e.g. robot1)");
  app.add_option("--devices-source", devices_source, "Poses of the localizers, or the simulator's ground truth")
      ->check(CLI::IsMember({"localizer", "ground_truth"}))
      ->capture_default_str();
  app.add_option("--rt-poll-ms", rt_poll_ms, "How often the naming service is read")
      ->check(CLI::Range(100, 600000))
      ->capture_default_str();
  app.add_option("--call-deadline-ms", call_deadline_ms, "Bound on an RT operation called through the gateway")
      ->check(CLI::Range(1, 3600000))
      ->capture_default_str();
  app.add_option("--idl", idl_files, "IDL file of an RT interface not built in (repeatable)");
  app.add_option("--max-clients", max_clients, "WebSocket clients at once")
      ->check(CLI::Range(1, 4096))
      ->capture_default_str();
  app.add_option("--max-queue-kib", max_queue_kib, "Bytes not yet sent to one client before it is dropped (KiB)")
      ->check(CLI::Range(64, 1048576))
      ->capture_default_str();
  app.add_option("--port-file", port_file, "Written with the bound port once listening (for tests)");
  app.add_option("--log-level", log_level, urs::util::kLogLevels)->envname("URS_LOG_LEVEL")->capture_default_str();
  std::string log_format = "text";
  urs::util::add_log_format_flag(app, log_format);
  std::string metrics_listen;
  urs::metrics::add_metrics_flag(app, metrics_listen);
  urs::util::TlsConfig tls;
  urs::util::add_tls_client_flags(app, tls);
  CLI11_PARSE(app, argc, argv);

  urs::util::block_shutdown_signals();
  gw::ServerOptions server_options;
  gw::LoginOptions login_options;
  std::optional<urs::planet::ClientOptions> planet;
  std::unique_ptr<urs::metrics::Metrics> metrics;
  try {
    urs::util::init_logging({"urs-gateway", log_level, log_format, space});
    metrics = urs::metrics::metrics_for(metrics_listen, "urs-gateway", space);
    if (playback) {
      std::string errors;
      for (const auto& [flag, given] :
           {std::pair{"--server", !server.empty()}, std::pair{"--naming", !naming.empty()},
            std::pair{"--dds-domain", dds_domain >= 0}, std::pair{"--devices-domain", devices_domain >= 0}}) {
        if (given) errors += std::string(errors.empty() ? "" : "; ") + "--playback: " + flag + " is given";
      }
      if (token_file.empty()) {
        errors += std::string(errors.empty() ? "" : "; ") + "--playback: give --token-file (the player's credential)";
      }
      if (!errors.empty()) throw urs::util::ConfigError(errors + " (a playback gateway attaches to no space)");
    } else if (server.empty() && naming.empty() && dds_domain < 0) {
      throw urs::util::ConfigError("give --server, --naming or --dds-domain (what the gateway shows), or --playback");
    }
    const auto endpoint = urs::util::parse_endpoint(listen, "--listen");
    server_options.host = endpoint.host;
    server_options.port = endpoint.port;
    server_options.web_dir = web_dir.empty() ? default_web_dir() : web_dir;
    if (!std::filesystem::exists(server_options.web_dir + "/index.html")) {
      throw urs::util::ConfigError("--web-dir: no index.html in '" + server_options.web_dir + "'");
    }
    server_options.space = space;
    if (anonymous != "none")
      server_options.anonymous = anonymous == "operator" ? gw::Role::operator_ : gw::Role::viewer;
    server_options.max_clients = static_cast<std::size_t>(max_clients);
    server_options.max_queue_bytes = static_cast<std::size_t>(max_queue_kib) * 1024;
    const std::string token = urs::util::read_token_file(token_file);
    if (!server.empty()) {
      const auto camus = urs::util::parse_endpoint(server, "--server");
      planet.emplace();
      planet->host = camus.host;
      planet->port = camus.port;
      planet->token = token;
      urs::util::check_tls_client(tls);
      planet->tls = tls;
      planet->peer_name = "urs-gateway@" + urs::util::host_name();
      planet->max_queued = 256;
      if (metrics) planet->calls = &metrics->client_calls("planet");  // its own and its logins' calls
      login_options.camus = *planet;
      login_options.camus->max_queued = 64;
    } else {
      login_options.space_token = token;
    }
    if (!naming.empty()) urs::util::parse_endpoint(naming, "--naming");
    login_options.viewer_token = urs::util::read_token_file(viewer_token_file);
    login_options.read_only = read_only;
    if (devices_domain >= 0 && split(robots).empty()) {
      throw urs::util::ConfigError("--devices-domain: name the robots to follow with --robots");
    }
    if (devices_domain >= 0 && devices_domain == dds_domain) {
      throw urs::util::ConfigError("--devices-domain " + std::to_string(devices_domain) +
                                   " is the link's --dds-domain: give the space's own devices domain");
    }
  } catch (const std::exception& e) {
    fmt::print(stderr, "urs-gateway: {}\n", e.what());
    return 2;
  }

  gw::HubOptions hub_options;
  hub_options.name = "urs-gateway " + space;
  hub_options.session_id = std::to_string(getpid()) + "-" + gw::random_id().substr(0, 8);
  hub_options.metadata = {{"space", space}};
  if (playback) hub_options.metadata.emplace_back("playback", "true");
  hub_options.client_publish = playback;
  gw::Hub hub(hub_options);
  gw::GatewayOptions view;
  view.space = space;
  if (!server.empty()) view.middlewares.push_back("camus");
  if (!naming.empty()) view.middlewares.push_back("rtc");
  view.dds = dds_domain >= 0;
  view.dds_domain = static_cast<uint32_t>(std::max(dds_domain, 0));
  gw::Gateway gateway(view, hub);
  if (playback) {
    hub.set_publish_handler([&gateway](const gw::Caller&, const std::string& topic, const std::string&,
                                       const std::string& payload) { return gw::replay(gateway, topic, payload); });
  }
  gw::Logins logins(login_options);

  std::unique_ptr<urs::rtc::Orb> orb;
  std::vector<std::unique_ptr<gw::SpaceSource>> sources;
  std::unique_ptr<gw::Server> http;
  std::unique_ptr<urs::metrics::HttpEndpoint> endpoint;  // declared last: stopped before what it reads
  try {
    if (planet) {
      gw::CamusSourceOptions options;
      options.space = space;
      options.client = *planet;
      sources.push_back(std::make_unique<gw::CamusSource>(options, logins));
    }
    if (!naming.empty()) {
      orb = std::make_unique<urs::rtc::Orb>(
          urs::rtc::OrbOptions{"", std::chrono::milliseconds(3000), std::chrono::milliseconds(2000)});
      gw::RtSourceOptions options;
      options.space = space;
      options.naming = naming;
      options.poll = std::chrono::milliseconds(rt_poll_ms);
      options.call_deadline = std::chrono::milliseconds(call_deadline_ms);
      options.idl = idl_files;
      sources.push_back(std::make_unique<gw::RtSource>(options, *orb));
    }
    if (dds_domain >= 0) {
      gw::DdsSourceOptions options;
      options.space = space;
      options.link.domain = static_cast<uint32_t>(dds_domain);
      options.link.lease = std::chrono::milliseconds(dds_lease_ms);
      options.link.udp_only = dds_udp_only;
      options.link.initial_peers = dds_peers;
      options.link.discovery_servers = dds_servers;
      if (!dds_tcp_connect.empty()) {
        options.link.transport = urs::federation::DdsOptions::Transport::kTcp;
        options.link.tcp.connect = dds_tcp_connect;
      }
      if (!dds_pki.empty())
        options.link.security = urs::federation::security_from_folder(dds_pki, gw::DdsSource::reader_name(space));
      options.own_services = server.empty() && naming.empty();
      options.own_state = server.empty();
      options.own_poses = devices_domain < 0;
      sources.push_back(std::make_unique<gw::DdsSource>(options));
    }
    if (devices_domain >= 0) {
      gw::WorldSourceOptions options;
      options.space = space;
      options.domain = static_cast<uint32_t>(devices_domain);
      options.ground_truth = devices_source == "ground_truth";
      options.robots = split(robots);
      sources.push_back(std::make_unique<gw::WorldSource>(options));
    }
    http = std::make_unique<gw::Server>(server_options, hub, logins);
    for (auto& source : sources) source->start(gateway);
    http->start();
    if (metrics) {
      metrics->health().add("serving", [] { return std::string(); });  // HTTP and WebSocket: started above
      metrics->add_scraped("urslink_gateway_clients", "WebSocket clients connected.", urs::metrics::Kind::kGauge,
                           [&hub] {
                             return std::vector<urs::metrics::Sample>{{{}, static_cast<double>(hub.clients())}};
                           });
    }
    endpoint = urs::metrics::serve(metrics_listen, metrics.get());
    if (!port_file.empty()) urs::util::write_file_atomically(port_file, std::to_string(http->port()));
    urs::util::notify_ready();  // systemd (Type=notify): serving HTTP and WebSocket
  } catch (const std::exception& e) {
    fmt::print(stderr, "urs-gateway: {}\n", e.what());
    for (auto& source : sources) source->stop();
    return 1;
  }
  spdlog::info("urs-gateway: space {} on http://{}:{}/ (dashboard) and ws://{}:{}/ (Foxglove WebSocket){}{}", space,
               server_options.host, http->port(), server_options.host, http->port(), read_only ? ", read only" : "",
               playback ? ", playing a recording" : "");

  const int signal = urs::util::wait_for_shutdown();
  spdlog::info("urs-gateway: signal {}, stopping", signal);
  endpoint.reset();
  for (auto& source : sources) source->stop();  // nothing is published any more
  http->stop();
  return 0;
}
