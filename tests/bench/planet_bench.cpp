// urs-bench: URSLink paths side by side with the native paths they add to, measured in one run.
//
//   urs-bench [--quick] [--pin] [--only TEXT]... [--json FILE] [--markdown FILE]
//
// --only TEXT measures only the rows ("path | payload") and measurements whose label contains
// TEXT (every --only given must match), and the baselines of those rows, to profile one path;
// the processes are started anyway.
// --pin runs the bench's client threads on CPU 0 and every server on CPU 1 (pinning.hpp).
//
// Rows, each for a 64-byte and a 921,600-byte reply:
//   - the wire: a raw TCP echo (one hop) and a raw TCP relay in front of it (two hops, what a
//     Planet call's client → server → SAM costs with nothing parsed); gRPC unary calls (one hop,
//     urs-grpc-echo in its own process), synchronous and through the callback API;
//   - a Planet call client → urs-camus-server → urs-sam → agent, from the C++ client (also over
//     TLS 1.3, and at 64 B with metrics on in the server and the SAM: a second space) and from
//     the Python SDK's (python_echo_bench.py, a process of its own);
//   - a direct omniORB call (static stubs) and the bridged paths both ways through urs-bridge;
//   - a direct Fast DDS request/reply (a DdsLink here, urs-dds-echo in its own process), plain
//     and with DDS-Security, and the cross-space paths both ways through two bridges linked by
//     DDS over UDP, plain and with DDS-Security (a second pair of bridges on a link of its own,
//     the PKI made by deploy/pki.sh at start), over the TCP link on loopback (a third pair), and
//     kr → jp at 64 B with metrics on in every process it crosses (a fourth pair, on the second
//     space's server, calling an rtc-manager of its own).
// The paths a goal compares are measured in turns (measure_interleaved) and their ratio taken
// repetition by repetition, with its spread. Also throughput with 1 and 4 clients (Planet against
// gRPC, bridged against direct omniORB, in turns) and with 4 across spaces (kr → jp over the link
// over TCP against the UDP link, in turns), a sustained image stream, discovery across
// spaces, recovery after a server kill -9, and resident memory of the server, SAM and bridges idle
// and with 1,000 services.
// Every process is real and runs on 127.0.0.1. Numbers are reported, never asserted.

#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <mutex>
#include <thread>

#include "Diagnostic.pb.h"
#include "bench_stats.hpp"
#include "camus.pb.h"
#include "certificates.hpp"
#include "corba_stub.hpp"
#include "dds_domain.hpp"
#include "grpc_client.hpp"
#include "naming_service.hpp"
#include "pinning.hpp"
#include "process.hpp"
#include "process_cost.hpp"
#include "raw_tcp.hpp"
#include "report.hpp"
#include "rt_provider.hpp"
#include "urs/federation/dds_link.hpp"
#include "urs/planet/call_adapter.hpp"
#include "urs/planet/client.hpp"
#include "urs/rtc/naming.hpp"
#include "urs/rtc/orb.hpp"
#include "urs/schema/schema.hpp"
#include "urs/util/cli.hpp"

namespace {

using namespace std::chrono_literals;
using urs::bench::Row;
using urs::bench::Summary;

// ---- a CAMUS space of real processes ------------------------------------------------------

// The flag that turns a program's metrics endpoint on (docs/operations.md, "Monitoring"), on a free port.
const std::vector<std::string> kMetricsOn{"--metrics-listen", "127.0.0.1:0"};

class Space {
 public:
  // With `tls`, the server speaks TLS 1.3 (certificates made in `dir`) and the SAM verifies it.
  // With `metrics`, the server and the SAM serve their metrics (kMetricsOn).
  explicit Space(const std::string& dir, bool tls = false, bool metrics = false)
      : dir_(dir), tls_(tls), metrics_(metrics) {
    std::ofstream(dir_ + "/sam.yaml") << "agents:\n  - {name: diag, type: diagnostic}\n";
    if (tls_) {
      urs::test::make_ca(dir_, "ca");
      urs::test::make_leaf(dir_, "server", "bench", "ca", "IP:127.0.0.1");
    }
    start_server(0);
    std::vector<std::string> argv{URS_SAM_BIN, "--space",          "bench",       "--server", address(),
                                  "--config",  dir_ + "/sam.yaml", "--log-level", "warn"};
    if (tls_) argv.insert(argv.end(), {"--tls-ca", ca_file()});
    if (metrics_) argv.insert(argv.end(), kMetricsOn.begin(), kMetricsOn.end());
    sam_ = std::make_unique<urs::test::Process>(urs::bench::server_command(argv), dir_ + "/sam.log");
  }
  std::string ca_file() const { return dir_ + "/ca.pem"; }
  void start_server(int port) {
    std::filesystem::remove(dir_ + "/port");
    std::vector<std::string> argv{
        URS_SERVER_BIN, "--space",      "bench",       "--listen",     "127.0.0.1:" + std::to_string(port),
        "--data-dir",   dir_ + "/data", "--port-file", dir_ + "/port", "--log-level",
        "warn"};
    if (tls_) argv.insert(argv.end(), {"--tls-cert", dir_ + "/server.pem", "--tls-key", dir_ + "/server.key"});
    if (metrics_) argv.insert(argv.end(), kMetricsOn.begin(), kMetricsOn.end());
    server_ = std::make_unique<urs::test::Process>(urs::bench::server_command(argv), dir_ + "/server.log");
    if (!urs::test::wait_until([&] { return std::filesystem::exists(dir_ + "/port"); }, 10s)) {
      throw std::runtime_error("server did not start: " + server_->log());
    }
    port_ = std::stoi(urs::test::read_text(dir_ + "/port"));
  }
  std::string address() const { return "127.0.0.1:" + std::to_string(port_); }
  uint16_t port() const { return static_cast<uint16_t>(port_); }
  urs::test::Process& server() { return *server_; }
  urs::test::Process& sam() { return *sam_; }

 private:
  std::string dir_;
  bool tls_ = false;
  bool metrics_ = false;
  int port_ = 0;
  std::unique_ptr<urs::test::Process> server_;
  std::unique_ptr<urs::test::Process> sam_;
};

std::unique_ptr<urs::planet::Client> connect(uint16_t port, urs::planet::Role role = urs::planet::CLIENT,
                                             const std::string& tls_ca = "") {
  urs::planet::ClientOptions options;
  options.port = port;
  options.role = role;
  options.tls.enabled = !tls_ca.empty();
  options.tls.ca_file = tls_ca;
  options.peer_name = "bench";
  auto client = std::make_unique<urs::planet::Client>(options);
  client->start();
  if (!client->wait_connected(5s)) throw std::runtime_error("bench client cannot connect: " + client->last_error());
  return client;
}

void expect_ok(const urs::planet::CallResult& r, const char* what) {
  if (!r.ok())
    throw std::runtime_error(std::string(what) + ": " + std::string(urs::planet::status_name(r.status)) + ": " +
                             r.message);
}

void expect_ok(const urs::call::Reply& r, const char* what) { expect_ok(urs::planet::to_call_result(r), what); }

long rss_kib(pid_t pid) { return urs::test::resident_kib(pid); }

// A server process (under server_command) that writes DIR/NAME.ready once it serves, which its
// `argv` names; returned once that file exists. Its output goes to DIR/NAME.log.
std::unique_ptr<urs::test::Process> start_until_ready(const std::string& dir, const std::string& name,
                                                      const std::vector<std::string>& argv) {
  auto process = std::make_unique<urs::test::Process>(urs::bench::server_command(argv), dir + "/" + name + ".log");
  if (!urs::test::wait_until([&] { return std::filesystem::exists(dir + "/" + name + ".ready"); }, 30s)) {
    throw std::runtime_error(name + " did not start: " + process->log());
  }
  return process;
}

// A real process started from a YAML configuration, up once its ready file exists.
std::unique_ptr<urs::test::Process> start_with_config(const std::string& dir, const std::string& name,
                                                      const std::string& yaml, std::vector<std::string> argv) {
  std::ofstream(dir + "/" + name + ".yaml") << yaml;
  argv.insert(argv.end(), {"--config", dir + "/" + name + ".yaml", "--ready-file", dir + "/" + name + ".ready",
                           "--log-level", "warn"});
  return start_until_ready(dir, name, argv);
}

// The Python SDK's client on the same space: tests/bench/python_echo_bench.py run in a process of
// its own (/usr/bin/python3 with python3-protobuf), its summary read from the JSON it prints.
urs::bench::Summary python_client_echo(const std::string& dir, uint16_t port, bool quick) {
  const std::string log = dir + "/python-bench.log";
  const std::string command =
      "/usr/bin/python3 '" URS_PYTHON_ECHO_BENCH "' --json --server 127.0.0.1:" + std::to_string(port) +
      (quick ? " --quick" : "") + " 2>'" + log + "'";
  FILE* pipe = ::popen(command.c_str(), "r");
  if (pipe == nullptr) throw std::runtime_error("cannot run " + command);
  std::string out;
  char buffer[512];
  while (std::fgets(buffer, sizeof(buffer), pipe) != nullptr) out += buffer;
  const int status = ::pclose(pipe);
  auto field = [&](const std::string& key) {
    const size_t at = out.find("\"" + key + "\": ");
    if (status != 0 || at == std::string::npos) {
      throw std::runtime_error("python_echo_bench.py (exit status " + std::to_string(status) + ") printed no " + key +
                               ": " + out + urs::test::read_text(log));
    }
    return std::stod(out.substr(at + key.size() + 4));
  };
  urs::bench::Summary summary;
  summary.median_us = field("median_us");
  summary.p99_us = field("p99_us");
  summary.min_median_us = field("min_median_us");
  summary.max_median_us = field("max_median_us");
  summary.samples = static_cast<size_t>(field("samples"));
  return summary;
}

}  // namespace

int main(int argc, char** argv) {
  bool quick = false;
  std::string json_path;
  std::string markdown_path;
  std::vector<std::string> only;
  for (int i = 1; i < argc; ++i) {
    std::string a = argv[i];
    if (a == "--quick")
      quick = true;
    else if (a == "--json" && i + 1 < argc)
      json_path = argv[++i];
    else if (a == "--markdown" && i + 1 < argc)
      markdown_path = argv[++i];
    else if (a == "--only" && i + 1 < argc)
      only.push_back(argv[++i]);
    else if (a == "--pin")
      urs::bench::pinning() = true;
    else {
      std::cerr << "usage: urs-bench [--quick] [--pin] [--only TEXT]... [--json FILE] [--markdown FILE]\n";
      return 2;
    }
  }
  signal(SIGPIPE, SIG_IGN);
  if (urs::bench::pinning()) urs::bench::pin_this_thread(urs::bench::kClientCpu);  // before any thread starts
  urs::util::init_logging("urs-bench", "warn");  // stderr; stdout carries only the report
  const int warmup = quick ? 20 : 500;
  const int iterations = quick ? 50 : 2000;
  const int big_iterations = quick ? 5 : 100;
  const int repetitions = quick ? 1 : 5;

  std::string dir = urs::test::make_temp_dir("bench");
  std::vector<Row> rows;
  std::vector<urs::bench::Extra> extras;
  auto wanted = [&only](const std::string& label) {
    return std::all_of(only.begin(), only.end(),
                       [&](const std::string& t) { return label.find(t) != std::string::npos; });
  };
  // A row measured by `run` (a Summary), unless --only leaves it out.
  auto add_row = [&](const std::string& path, const std::string& payload, auto&& run, std::string baseline,
                     double goal) {
    if (wanted(path + " | " + payload)) rows.push_back({path, payload, run(), std::move(baseline), goal});
  };
  // Paths measured in turns (measure_interleaved), each compared with its baseline repetition by
  // repetition. Of a group, --only measures the paths it wants and the baselines of those (a sum's
  // parts), nothing else; without --only, every path.
  struct GroupPath {
    std::string path;  // "" for a path measured only as a part of sums
    std::function<void()> once;
    std::string baseline;  // "path|payload" of a path or a sum of the same group
    double goal = 0;
  };
  // A row made of the group's paths run one after the other: the native hops a bridged call adds
  // up (sum_of), or one path compared with another baseline (one part).
  struct GroupSum {
    std::string path;
    std::vector<size_t> parts;  // indices into the group's paths
    std::string baseline;
    double goal = 0;
  };
  int groups = 0;
  auto add_group = [&](const std::string& payload, const std::vector<GroupPath>& paths,
                       const std::vector<GroupSum>& sums, int w, int n) {
    std::vector<bool> needed(paths.size(), false);
    auto need = [&](const std::string& name) {  // a path or a sum named "path|payload"
      for (size_t i = 0; i < paths.size(); ++i) {
        if (!paths[i].path.empty() && paths[i].path + "|" + payload == name) needed[i] = true;
      }
      for (const auto& sum : sums) {
        if (sum.path + "|" + payload != name) continue;
        for (size_t part : sum.parts) needed[part] = true;
      }
    };
    for (const auto& p : paths) {
      if (p.path.empty() || !wanted(p.path + " | " + payload)) continue;
      need(p.path + "|" + payload);
      need(p.baseline);
    }
    for (const auto& sum : sums) {
      if (!wanted(sum.path + " | " + payload)) continue;
      need(sum.path + "|" + payload);
      need(sum.baseline);
    }
    std::vector<Summary> summaries(paths.size());
    if (std::none_of(needed.begin(), needed.end(), [](bool b) { return b; })) return summaries;
    std::vector<std::function<void()>> calls;
    for (size_t i = 0; i < paths.size(); ++i) {
      if (needed[i]) calls.push_back(paths[i].once);
    }
    std::vector<Summary> measured = urs::bench::measure_interleaved(calls, w, n, repetitions);
    ++groups;
    for (size_t i = 0, m = 0; i < paths.size(); ++i) {
      if (!needed[i]) continue;
      summaries[i] = measured[m++];
      if (!paths[i].path.empty())
        rows.push_back({paths[i].path, payload, summaries[i], paths[i].baseline, paths[i].goal, groups});
    }
    for (const auto& sum : sums) {
      if (!std::all_of(sum.parts.begin(), sum.parts.end(), [&](size_t part) { return needed[part]; })) continue;
      std::vector<const Summary*> parts;
      for (size_t part : sum.parts) parts.push_back(&summaries[part]);
      rows.push_back({sum.path, payload, parts.size() == 1 ? *parts[0] : urs::bench::sum_of(parts), sum.baseline,
                      sum.goal, groups});
    }
    return summaries;
  };
  try {
    urs::bench::RawEcho echo;
    urs::bench::RawRelay relay(echo.port());
    urs::bench::GrpcEchoProcess grpc_echo(urs::bench::server_command({URS_GRPC_ECHO_BIN}), dir);
    Space space(dir);
    auto client = connect(space.port());
    if (!urs::test::wait_until(
            [&] {
              URS::Diagnostic_echo_Request probe;
              return client->call("diag", "echo", probe.SerializeAsString(), 500ms).ok();
            },
            10s)) {
      throw std::runtime_error("diag never became callable: " + space.sam().log());
    }
    // The same path with every connection TLS 1.3.
    std::filesystem::create_directories(dir + "/tls");
    Space tls_space(dir + "/tls", /*tls=*/true);
    auto tls_client = connect(tls_space.port(), urs::planet::CLIENT, tls_space.ca_file());
    // The same path with metrics on in the server and the SAM (the space above has them off).
    std::filesystem::create_directories(dir + "/metrics");
    Space metrics_space(dir + "/metrics", /*tls=*/false, /*metrics=*/true);
    auto metrics_client = connect(metrics_space.port());

    URS::Diagnostic_echo_Request echo_req;
    echo_req.set_text(std::string(64, 'x'));
    const std::string echo_payload = echo_req.SerializeAsString();
    URS::Diagnostic_blob_Request blob_req;
    blob_req.set_size(921600);
    const std::string blob_payload = blob_req.SerializeAsString();
    if (!urs::test::wait_until([&] { return tls_client->call("diag", "echo", echo_payload, 500ms).ok(); }, 10s)) {
      throw std::runtime_error("diag over TLS never became callable: " + tls_space.sam().log());
    }
    if (!urs::test::wait_until([&] { return metrics_client->call("diag", "echo", echo_payload, 500ms).ok(); }, 10s)) {
      throw std::runtime_error("diag with metrics on never became callable: " + metrics_space.sam().log());
    }

    // One request, one reply, on each path of one space, in turns: the wire (one hop, and two hops
    // through a relay that parses nothing), gRPC unary (one hop) and Planet (two hops).
    const int raw_fd = urs::bench::connect_loopback(echo.port());
    const int relay_fd = urs::bench::connect_loopback(relay.port());
    urs::bench::GrpcClient grpc_sync(grpc_echo.sync_port());
    urs::bench::GrpcClient grpc_async(grpc_echo.callback_port());
    const std::string raw_small(64, 'x');
    const std::string raw_big_request = urs::bench::blob_request(921600);
    std::string raw_reply;
    urs::bench::EchoMessage grpc_small;
    grpc_small.set_data(std::string(64, 'x'));
    urs::bench::EchoMessage grpc_big;
    grpc_big.set_reply_size(921600);
    const std::string kRaw = "raw TCP echo (one hop)";
    const std::string kRelay = "raw TCP relay client→relay→echo (two hops)";
    const std::string kGrpcSync = "gRPC unary, synchronous (one hop)";
    const std::string kGrpcAsync = "gRPC unary, asynchronous callback API (one hop)";
    const std::string kPlanet = "Planet call client→server→SAM→SA";
    for (const bool big_payload : {false, true}) {
      const std::string size = big_payload ? "921,600 B" : "64 B";
      const std::string& raw_request = big_payload ? raw_big_request : raw_small;
      const urs::bench::EchoMessage& grpc_request = big_payload ? grpc_big : grpc_small;
      const std::string op = big_payload ? "blob" : "echo";
      const std::string& payload = big_payload ? blob_payload : echo_payload;
      std::vector<GroupPath> paths{
          {kRaw, [&] { urs::bench::round_trip(raw_fd, raw_request, raw_reply); }, "", 0},
          {kRelay, [&] { urs::bench::round_trip(relay_fd, raw_request, raw_reply); }, kRaw + "|" + size, 0},
          {kGrpcSync, [&] { grpc_sync.call(grpc_request); }, "", 0},
          {kGrpcAsync, [&] { grpc_async.call_async(grpc_request); }, kGrpcSync + "|" + size, 0},
          {kPlanet, [&] { expect_ok(client->call("diag", op, payload, 10s), op.c_str()); }, kRelay + "|" + size,
           big_payload ? 1.5 : 1.25},
      };
      if (!big_payload) {
        paths.push_back({"Planet call over TLS 1.3 client→server→SAM→SA",
                         [&] { expect_ok(tls_client->call("diag", "echo", echo_payload, 5s), "echo"); },
                         kPlanet + "|" + size, 1.2});
        paths.push_back({"Planet call, metrics on in server and SAM: client→server→SAM→SA",
                         [&] { expect_ok(metrics_client->call("diag", "echo", echo_payload, 5s), "echo"); },
                         kPlanet + "|" + size, 1.05});
      }
      // The Planet call's round again, its goal against the one-hop gRPC call.
      add_group(
          size, paths,
          {{"Planet call (two hops) against gRPC unary (one hop)", {4}, kGrpcSync + "|" + size, big_payload ? 0 : 1.0}},
          big_payload ? 3 : warmup, big_payload ? big_iterations : iterations);
    }
    add_row(
        "Planet call, Python client (urslink)→server→SAM→SA", "64 B",
        [&] { return python_client_echo(dir, space.port(), quick); }, kPlanet + "|64 B", 0);
    close(raw_fd);
    close(relay_fd);

    // Throughput with 1 and 4 concurrent clients, 64 B: Planet and gRPC (each client a
    // connection of its own), in turns, `repetitions` rounds.
    for (int clients : {1, 4}) {
      const std::string label = "throughput, " + std::to_string(clients) + " client(s), 64 B: Planet and gRPC";
      if (!wanted(label)) continue;
      std::vector<std::unique_ptr<urs::planet::Client>> planets;
      std::vector<std::unique_ptr<urs::bench::GrpcClient>> grpcs;
      for (int c = 0; c < clients; ++c) {
        planets.push_back(connect(space.port()));
        grpcs.push_back(std::make_unique<urs::bench::GrpcClient>(grpc_echo.sync_port()));
        grpcs.push_back(std::make_unique<urs::bench::GrpcClient>(grpc_echo.callback_port()));
      }
      const int per_client = quick ? 200 : 3000;
      std::vector<double> planet_rate, sync_rate, async_rate, against_async;
      for (int r = 0; r < repetitions; ++r) {
        planet_rate.push_back(urs::bench::throughput(clients, per_client, [&](int c) {
          return [cl = planets[static_cast<size_t>(c)].get(), &echo_payload] {
            expect_ok(cl->call("diag", "echo", echo_payload, 5s), "echo");
          };
        }));
        sync_rate.push_back(urs::bench::throughput(clients, per_client, [&](int c) {
          return [cl = grpcs[static_cast<size_t>(2 * c)].get(), &grpc_small] { cl->call(grpc_small); };
        }));
        async_rate.push_back(urs::bench::throughput(clients, 1,
                                                    [&](int c) {
                                                      return [cl = grpcs[static_cast<size_t>(2 * c + 1)].get(),
                                                              &grpc_small,
                                                              per_client] { cl->chain_async(grpc_small, per_client); };
                                                    }) *
                             per_client);
        against_async.push_back(planet_rate.back() / async_rate.back());
      }
      char value[256];
      std::snprintf(
          value, sizeof(value),
          "Planet %.0f calls/s, gRPC synchronous %.0f, gRPC asynchronous %.0f; Planet/gRPC async %.2f (%.2f – %.2f)%s",
          urs::bench::percentile(planet_rate, 0.5), urs::bench::percentile(sync_rate, 0.5),
          urs::bench::percentile(async_rate, 0.5), urs::bench::percentile(against_async, 0.5),
          *std::min_element(against_async.begin(), against_async.end()),
          *std::max_element(against_async.begin(), against_async.end()),
          clients == 4
              ? (urs::bench::percentile(against_async, 0.5) >= 1.0 ? " (goal >= 1: met)" : " (goal >= 1: missed)")
              : "");
      extras.push_back({label, value});
    }

    // ---- the RT side, a bridge in the space, and two spaces linked over DDS -------------------
    // The spaces' link, plain and secured; the direct DDS rows', plain and secured; the link over TCP.
    const urs::test::DdsDomains domains(6);
    const int domain = static_cast<int>(domains[0]);
    // One federation made by deploy/pki.sh for every secured row: kr and jp call each other over
    // the secured link, dds-a calls dds-b (the direct rows).
    const std::string pki = dir + "/pki";
    urs::test::run_pki({{"init", pki},
                        {"governance", pki},
                        {"member", pki, "kr", "--calls", "jp"},
                        {"member", pki, "jp", "--calls", "kr"},
                        {"member", pki, "dds-a", "--calls", "dds-b"},
                        {"member", pki, "dds-b"}});
    urs::test::NamingService naming(dir + "/naming");
    auto manager = start_with_config(
        dir, "rtc", "components:\n  - type: Diagnostic\n",
        {URS_RTC_MANAGER_BIN, "--space", "bench", "--naming", naming.address(), "--host", "benchhost"});
    auto bridge = start_with_config(
        dir, "bridge",
        "name: bridge-bench\n"
        "rt_to_camus: {poll_ms: 100, providers: [{match: \"benchhost.host_cxt/Diagnostic0.rtc\", name: rt.diag, "
        "deadline_ms: 30000}]}\n"
        "camus_to_rt: {poll_ms: 100, services: [{match: diag, instance: camus_diag, deadline_ms: 30000}]}\n",
        {URS_BRIDGE_BIN, "--space", "bench", "--server", space.address(), "--naming", naming.address(), "--host",
         "benchhost"});
    const std::string dds = "dds: {domain: " + std::to_string(domain) + ", lease_ms: 3000, udp_only: true";
    auto bridge_jp = start_with_config(
        dir, "bridge-jp",
        "name: bridge-jp\n"
        "rt_to_camus: {poll_ms: 100, providers: [{match: \"benchhost.host_cxt/Diagnostic0.rtc\", name: rt.diag},\n"
        "                                        {match: \"disc*\", name: \"{instance}@{host}\"}]}\n" +
            dds + ", import: {allow: [kr/diag]}}\n",
        {URS_BRIDGE_BIN, "--space", "jp", "--naming", naming.address(), "--host", "jphost"});
    auto bridge_kr = start_with_config(dir, "bridge-kr", "name: bridge-kr\n" + dds + "}\n",
                                       {URS_BRIDGE_BIN, "--space", "kr", "--server", space.address()});
    // The same two bridges on a DDS-Security link of their own (domain and PKI above), the
    // imports named apart from the plain link's: jp-secured/rt.diag in kr, the RTC kr_diag bound
    // under host jpsecured in jp. kr offers only diag on it and takes no state from it (the plain
    // link's bridge-kr writes jp's state into the context).
    const std::string secured_dds = "dds: {domain: " + std::to_string(domains[3]) +
                                    ", lease_ms: 3000, udp_only: true, security: {pki: \"" + pki + "\"}";
    auto secured_jp = start_with_config(
        dir, "secured-bridge-jp",
        "name: secured-bridge-jp\n"
        "rt_to_camus: {poll_ms: 100, providers: [{match: \"benchhost.host_cxt/Diagnostic0.rtc\", name: rt.diag}]}\n" +
            secured_dds + ", import: {allow: [kr/diag]}}\n",
        {URS_BRIDGE_BIN, "--space", "jp", "--naming", naming.address(), "--host", "jpsecured"});
    auto secured_kr = start_with_config(
        dir, "secured-bridge-kr",
        "name: secured-bridge-kr\n" + secured_dds +
            ", export: {allow: [diag]}, import: {as_camus: \"{space}-secured/{service}\"}, state: {import: false}}\n",
        {URS_BRIDGE_BIN, "--space", "kr", "--server", space.address()});
    // The same two spaces over the TCP link (docs/sites.md) on loopback, on a domain of its own: jp
    // listens, kr connects; imports named apart (jp-tcp/rt.diag in kr, kr_diag under host jptcp).
    const std::string tcp_port = std::to_string(urs::test::free_tcp_port());
    const std::string tcp_dds = "dds: {domain: " + std::to_string(domains[4]) + ", lease_ms: 3000, transport: tcp";
    auto tcp_jp = start_with_config(
        dir, "tcp-bridge-jp",
        "name: tcp-bridge-jp\n"
        "rt_to_camus: {poll_ms: 100, providers: [{match: \"benchhost.host_cxt/Diagnostic0.rtc\", name: rt.diag}]}\n" +
            tcp_dds + ", tcp: {listen: " + tcp_port + ", public: 127.0.0.1}, import: {allow: [kr/diag]}}\n",
        {URS_BRIDGE_BIN, "--space", "jp", "--naming", naming.address(), "--host", "jptcp"});
    auto tcp_kr = start_with_config(dir, "tcp-bridge-kr",
                                    "name: tcp-bridge-kr\n" + tcp_dds + ", tcp: {connect: [\"127.0.0.1:" + tcp_port +
                                        "\"]}, export: {allow: [diag]}, import: {as_camus: \"{space}-tcp/{service}\"}, "
                                        "state: {import: false}}\n",
                                    {URS_BRIDGE_BIN, "--space", "kr", "--server", space.address()});
    // The plain link's path again with metrics on in every process it crosses: the metrics space's
    // server (above), a pair of bridges on a link of its own (domain above) and an rtc-manager of
    // its own under host benchmetrics; imports named apart (jp-metrics/rt.diag in kr's metrics
    // space, kr_diag under host jpmetrics in jp).
    std::vector<std::string> metrics_manager_argv{URS_RTC_MANAGER_BIN, "--space", "bench",       "--naming",
                                                  naming.address(),    "--host",  "benchmetrics"};
    metrics_manager_argv.insert(metrics_manager_argv.end(), kMetricsOn.begin(), kMetricsOn.end());
    auto metrics_manager =
        start_with_config(dir, "metrics-rtc", "components:\n  - type: Diagnostic\n", metrics_manager_argv);
    const std::string metrics_dds = "dds: {domain: " + std::to_string(domains[5]) + ", lease_ms: 3000, udp_only: true";
    std::vector<std::string> metrics_jp_argv{URS_BRIDGE_BIN,   "--space", "jp",       "--naming",
                                             naming.address(), "--host",  "jpmetrics"};
    metrics_jp_argv.insert(metrics_jp_argv.end(), kMetricsOn.begin(), kMetricsOn.end());
    auto metrics_jp = start_with_config(dir, "metrics-bridge-jp",
                                        "name: metrics-bridge-jp\n"
                                        "rt_to_camus: {poll_ms: 100, providers: [{match: "
                                        "\"benchmetrics.host_cxt/Diagnostic0.rtc\", name: rt.diag}]}\n" +
                                            metrics_dds + ", import: {allow: [kr/diag]}}\n",
                                        metrics_jp_argv);
    std::vector<std::string> metrics_kr_argv{URS_BRIDGE_BIN, "--space", "kr", "--server", metrics_space.address()};
    metrics_kr_argv.insert(metrics_kr_argv.end(), kMetricsOn.begin(), kMetricsOn.end());
    auto metrics_kr = start_with_config(
        dir, "metrics-bridge-kr",
        "name: metrics-bridge-kr\n" + metrics_dds + ", import: {as_camus: \"{space}-metrics/{service}\"}}\n",
        metrics_kr_argv);
    auto callable = [&](const std::string& service, std::chrono::seconds within = 30s) {
      return urs::test::wait_until([&] { return client->call(service, "echo", echo_payload, 500ms).ok(); }, within);
    };
    if (!urs::test::wait_until(
            [&] { return metrics_client->call("jp-metrics/rt.diag", "echo", echo_payload, 500ms).ok(); }, 30s)) {
      throw std::runtime_error("jp-metrics/rt.diag never became callable over the link with metrics on: " +
                               metrics_kr->log() + metrics_jp->log());
    }
    if (!callable("rt.diag") || !callable("jp/rt.diag")) {
      throw std::runtime_error("the bridged services never became callable: " + bridge->log() + bridge_kr->log());
    }
    // A first link over TCP may take Fast DDS's connection retries past 20 s on a loaded machine,
    // and on one host it sometimes never forms (docs/sites.md, Limits): its rows are then left out.
    const bool tcp_linked = callable("jp-tcp/rt.diag", 60s);
    if (!tcp_linked) {
      extras.push_back(
          {"the link over TCP on loopback", "did not link within 60 s: its rows are left out (docs/sites.md, Limits)"});
    }
    if (!callable("jp-secured/rt.diag")) {
      throw std::runtime_error("jp-secured/rt.diag never became callable over the secured link: " + secured_kr->log() +
                               secured_jp->log());
    }
    urs::rtc::Orb orb;
    urs::rtc::NamingClient names(orb, naming.address());
    CORBA::Object_var direct_object =
        urs::bench::provider(orb, names, "benchhost.host_cxt/Diagnostic0.rtc", "diagnostic");
    urs::bench::DiagnosticStub direct(direct_object);
    if (!urs::test::wait_until(
            [&] {
              CORBA::Object_var bound = names.try_resolve("benchhost.host_cxt/camus_diag.rtc");
              CORBA::Object_var kr_bound = names.try_resolve("jphost.host_cxt/kr_diag.rtc");
              CORBA::Object_var secured_bound = names.try_resolve("jpsecured.host_cxt/kr_diag.rtc");
              CORBA::Object_var tcp_bound = names.try_resolve("jptcp.host_cxt/kr_diag.rtc");
              return !CORBA::is_nil(bound) && !CORBA::is_nil(kr_bound) && !CORBA::is_nil(secured_bound) &&
                     (!tcp_linked || !CORBA::is_nil(tcp_bound));
            },
            30s)) {
      throw std::runtime_error("the RTCs standing for diag never appeared: " + bridge->log() + bridge_jp->log() +
                               secured_jp->log() + tcp_jp->log());
    }
    CORBA::Object_var imported_object =
        urs::bench::provider(orb, names, "benchhost.host_cxt/camus_diag.rtc", "diagnostic");
    urs::bench::DiagnosticStub imported(imported_object);
    CORBA::Object_var remote_object = urs::bench::provider(orb, names, "jphost.host_cxt/kr_diag.rtc", "diagnostic");
    urs::bench::DiagnosticStub remote(remote_object);
    CORBA::Object_var secured_remote_object =
        urs::bench::provider(orb, names, "jpsecured.host_cxt/kr_diag.rtc", "diagnostic");
    urs::bench::DiagnosticStub secured_remote(secured_remote_object);
    CORBA::Object_var tcp_remote_object =
        tcp_linked ? urs::bench::provider(orb, names, "jptcp.host_cxt/kr_diag.rtc", "diagnostic")
                   : CORBA::Object::_duplicate(remote_object);
    urs::bench::DiagnosticStub tcp_remote(tcp_remote_object);  // the plain link's stub if none (never called then)

    // Direct Fast DDS request/reply: a DdsLink here and one in urs-dds-echo answering at once (UDP
    // only, between processes as the bridges are).
    auto dds_echo =
        start_until_ready(dir, "dds-echo", {URS_DDS_ECHO_BIN, std::to_string(domains[1]), dir + "/dds-echo.ready"});
    urs::federation::DdsOptions a_options;
    a_options.domain = domains[1];
    a_options.space = "dds-a";
    a_options.bridge = "a";
    a_options.udp_only = true;
    urs::federation::DdsLink dds_a(
        a_options, [] {}, [](urs::call::Request, urs::call::Responder) {});
    expect_ok(dds_a.call("dds-b", "echo", "echo", echo_payload, 5s), "direct DDS");
    // The same with DDS-Security (the federation above, data encrypted), on a domain of its own.
    auto secured_echo = start_until_ready(
        dir, "secured-echo", {URS_DDS_ECHO_BIN, std::to_string(domains[2]), dir + "/secured-echo.ready", pki});
    urs::federation::DdsOptions secured_options = a_options;
    secured_options.domain = domains[2];
    secured_options.security = urs::federation::security_from_folder(pki, "dds-a");
    urs::federation::DdsLink secured_a(
        secured_options, [] {}, [](urs::call::Request, urs::call::Responder) {});
    const auto handshake_start = std::chrono::steady_clock::now();
    if (!urs::test::wait_until([&] { return secured_a.call("dds-b", "echo", "echo", echo_payload, 1s).ok(); }, 30s)) {
      throw std::runtime_error("the secured DDS echo never answered: " + secured_echo->log());
    }
    char handshake[96];
    std::snprintf(
        handshake, sizeof(handshake), "%.0f ms (authentication, then the first call's writer matched)",
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - handshake_start).count());
    extras.push_back({"DDS-Security: joining until the first call is answered", handshake});

    const std::string text(64, 'x');
    for (const bool big_payload : {false, true}) {
      const char* size = big_payload ? "921,600 B" : "64 B";
      const int n = big_payload ? big_iterations : iterations;
      const int w = big_payload ? 3 : warmup;
      const std::string op = big_payload ? "blob" : "echo";
      const std::string& payload = big_payload ? blob_payload : echo_payload;
      auto stub_call = [&](urs::bench::DiagnosticStub& stub) {
        return [&stub, big_payload, &text] {
          if (big_payload)
            stub.blob(921600);
          else
            stub.echo(text);
        };
      };
      auto planet_call = [&](const std::string& service) {
        return [&, service] { expect_ok(client->call(service, op, payload, 10s), service.c_str()); };
      };
      auto metrics_call = [&](const std::string& service) {
        return [&, service] { expect_ok(metrics_client->call(service, op, payload, 10s), service.c_str()); };
      };
      // In turns: the native paths, the same Planet call as above (its round is needed in this
      // group for the sums), the bridged and the cross-space paths, plain and secured.
      const std::string kOmni = "omniORB call, static stubs (direct)";
      const std::string kDds = "Fast DDS request/reply, UDP (direct)";
      const std::string kBridgeHops = "Planet call + omniORB call (the hops of a bridged call)";
      const std::string kHops = "sum of the native hops (Planet + Fast DDS + omniORB)";
      const std::string kCrossToJp = "cross-space: kr client→server→bridge-kr→DDS→bridge-jp→RTC";
      const std::string kCrossToKr = "cross-space: jp stub→bridge-jp→DDS→bridge-kr→server→SAM→SA";
      const std::string at = std::string("|") + size;
      const double secured_goal = big_payload ? 1.5 : 1.3;
      add_group(
          size,
          {{kOmni, stub_call(direct), "", 0},
           {kDds, [&] { expect_ok(dds_a.call("dds-b", "x", op, payload, 10s), "DDS"); }, "", 0},
           {"Fast DDS request/reply, UDP, DDS-Security encrypted (direct)",
            [&] { expect_ok(secured_a.call("dds-b", "x", op, payload, 10s), "secured DDS"); }, kDds + at, secured_goal},
           {"", planet_call("diag"), "", 0},  // the Planet call's round of this group (no row of its own)
           {"bridged RTC→CAMUS: client→server→bridge→RTC", planet_call("rt.diag"), kBridgeHops + at,
            big_payload ? 0 : 1.15},
           {"bridged SA→RT: stub→bridge→server→SAM→SA", stub_call(imported), kBridgeHops + at, 0},
           {kCrossToJp, planet_call("jp/rt.diag"), kHops + at, 1.2},
           {kCrossToKr, stub_call(remote), kHops + at, 1.2},
           {"cross-space, DDS-Security encrypted: kr client→server→bridge-kr→DDS→bridge-jp→RTC",
            planet_call("jp-secured/rt.diag"), kCrossToJp + at, secured_goal},
           {"cross-space, DDS-Security encrypted: jp stub→bridge-jp→DDS→bridge-kr→server→SAM→SA",
            stub_call(secured_remote), kCrossToKr + at, secured_goal},
           {tcp_linked ? "cross-space, the link over TCP: kr client→server→bridge-kr→TCP→bridge-jp→RTC" : "",
            planet_call("jp-tcp/rt.diag"), tcp_linked ? kCrossToJp + at : "", 1.2},
           // Not at 921,600 B: a reply that large from the connecting site to the listening one
           // takes 160-240 ms and once stalled past the call's 10 s deadline (docs/sites.md, Limits).
           {big_payload || !tcp_linked
                ? ""
                : "cross-space, the link over TCP: jp stub→bridge-jp→TCP→bridge-kr→server→SAM→SA",
            stub_call(tcp_remote), big_payload || !tcp_linked ? "" : kCrossToKr + at, 1.2},
           // At 64 B only, what metrics cost the call (docs/operations.md, "Monitoring").
           {big_payload ? "" : "cross-space, metrics on in every process: kr client→server→bridge-kr→DDS→bridge-jp→RTC",
            metrics_call("jp-metrics/rt.diag"), big_payload ? "" : kCrossToJp + at, 1.05}},
          // The native hops each bridged path traverses, added up repetition by repetition.
          {{kBridgeHops, {3, 0}, "", 0}, {kHops, {3, 1, 0}, "", 0}}, w, n);
    }

    // What each 64-byte path costs the processes it crosses, per call (process_cost.hpp): the
    // thread hand-offs between a path and the wire, counted rather than timed; and the same for
    // the Planet path's 921,600-byte reply.
    {
      const std::string text(64, 'x');
      auto cost_per_call = [&](const std::string& path, const std::vector<std::pair<std::string, pid_t>>& processes,
                               const std::function<void()>& once, bool big = false) {
        const std::string label = std::string(big ? "cost per 921,600-byte call" : "cost per 64-byte call") +
                                  " (voluntary context switches, CPU): " + path;
        if (!wanted(label)) return;
        const int n = big ? (quick ? 20 : 500) : (quick ? 200 : 5000);
        for (int i = 0; i < 50; ++i) once();
        std::vector<urs::bench::ProcessCost> before;
        for (const auto& process : processes) before.push_back(urs::bench::process_cost(process.second));
        for (int i = 0; i < n; ++i) once();
        std::string value;
        for (size_t i = 0; i < processes.size(); ++i) {
          const auto after = urs::bench::process_cost(processes[i].second);
          char part[128];
          std::snprintf(part, sizeof(part), "%s%s %.2f, %.0f us", value.empty() ? "" : "; ", processes[i].first.c_str(),
                        static_cast<double>(after.voluntary_switches - before[i].voluntary_switches) / n,
                        static_cast<double>(after.cpu_ns - before[i].cpu_ns) / n / 1000.0);
          value += part;
        }
        extras.push_back({label, value});
      };
      auto echo_to = [&](const std::string& service) {
        return [&, service] { expect_ok(client->call(service, "echo", echo_payload, 10s), service.c_str()); };
      };
      const pid_t server = space.server().pid(), sam = space.sam().pid(), rtc = manager->pid();
      cost_per_call("omniORB call, static stubs (direct)", {{"rtc-manager", rtc}}, [&] { direct.echo(text); });
      cost_per_call("Fast DDS request/reply, UDP (direct)", {{"urs-dds-echo", dds_echo->pid()}},
                    [&] { expect_ok(dds_a.call("dds-b", "x", "echo", echo_payload, 10s), "DDS"); });
      cost_per_call(kPlanet, {{"server", server}, {"SAM", sam}}, echo_to("diag"));
      cost_per_call("Planet call, metrics on in server and SAM: client→server→SAM→SA",
                    {{"server", metrics_space.server().pid()}, {"SAM", metrics_space.sam().pid()}},
                    [&] { expect_ok(metrics_client->call("diag", "echo", echo_payload, 10s), "diag"); });
      cost_per_call(
          kPlanet, {{"server", server}, {"SAM", sam}},
          [&] { expect_ok(client->call("diag", "blob", blob_payload, 10s), "diag blob"); }, true);
      cost_per_call("bridged RTC→CAMUS: client→server→bridge→RTC",
                    {{"server", server}, {"bridge", bridge->pid()}, {"rtc-manager", rtc}}, echo_to("rt.diag"));
      cost_per_call("bridged SA→RT: stub→bridge→server→SAM→SA",
                    {{"bridge", bridge->pid()}, {"server", server}, {"SAM", sam}}, [&] { imported.echo(text); });
      cost_per_call(
          "cross-space: kr client→server→bridge-kr→DDS→bridge-jp→RTC",
          {{"server", server}, {"bridge-kr", bridge_kr->pid()}, {"bridge-jp", bridge_jp->pid()}, {"rtc-manager", rtc}},
          echo_to("jp/rt.diag"));
      cost_per_call("cross-space, metrics on in every process: kr client→server→bridge-kr→DDS→bridge-jp→RTC",
                    {{"server", metrics_space.server().pid()},
                     {"bridge-kr", metrics_kr->pid()},
                     {"bridge-jp", metrics_jp->pid()},
                     {"rtc-manager", metrics_manager->pid()}},
                    [&] { expect_ok(metrics_client->call("jp-metrics/rt.diag", "echo", echo_payload, 10s), "echo"); });
      cost_per_call(
          "cross-space: jp stub→bridge-jp→DDS→bridge-kr→server→SAM→SA",
          {{"bridge-jp", bridge_jp->pid()}, {"bridge-kr", bridge_kr->pid()}, {"server", server}, {"SAM", sam}},
          [&] { remote.echo(text); });
    }

    // Throughput, direct omniORB and bridged RTC→CAMUS, 1 and 4 clients, in turns.
    const int per = quick ? 100 : 3000;
    for (int clients : {1, 4}) {
      if (!wanted("throughput RTC→CAMUS, " + std::to_string(clients) + " client(s), 64 B")) continue;
      std::vector<std::unique_ptr<urs::bench::DiagnosticStub>> stubs;
      std::vector<std::unique_ptr<urs::planet::Client>> planets;
      for (int c = 0; c < clients; ++c) {
        CORBA::Object_var object = urs::bench::provider(orb, names, "benchhost.host_cxt/Diagnostic0.rtc", "diagnostic");
        stubs.push_back(std::make_unique<urs::bench::DiagnosticStub>(object));
        planets.push_back(connect(space.port()));
      }
      std::vector<double> corba, bridged, share;
      for (int r = 0; r < repetitions; ++r) {
        corba.push_back(urs::bench::throughput(clients, per, [&](int c) {
          return [stub = stubs[static_cast<size_t>(c)].get(), &text] { stub->echo(text); };
        }));
        bridged.push_back(urs::bench::throughput(clients, per, [&](int c) {
          return [cl = planets[static_cast<size_t>(c)].get(), &echo_payload] {
            expect_ok(cl->call("rt.diag", "echo", echo_payload, 5s), "echo");
          };
        }));
        share.push_back(bridged.back() / corba.back());
      }
      const double median_share = urs::bench::percentile(share, 0.5);
      char value[200];
      std::snprintf(value, sizeof(value), "%.0f calls/s bridged vs %.0f direct omniORB: %.0f%% (%.0f – %.0f%%)%s",
                    urs::bench::percentile(bridged, 0.5), urs::bench::percentile(corba, 0.5), 100 * median_share,
                    100 * *std::min_element(share.begin(), share.end()),
                    100 * *std::max_element(share.begin(), share.end()),
                    clients == 4 ? (median_share >= 0.35 ? " (goal >= 35%: met)" : " (goal >= 35%: missed)") : "");
      extras.push_back({"throughput RTC→CAMUS, " + std::to_string(clients) + " client(s), 64 B", value});
    }

    // Throughput across spaces with 4 clients, 64 B: kr → jp over the link over TCP and over the UDP
    // link, in turns. The TCP link's goal, <= 1.2x the UDP link, is >= 0.83 of its calls/s here. A
    // call that fails is counted (it runs on a thread of throughput()) and the rate is of those
    // answered: the TCP link on loopback has stalled past the 10 s deadline under 4 clients, and
    // a full run of 3,000 (then 500) calls a client per repetition did not end within 18 minutes,
    // bridge-jp's TCP receive thread busy all along (docs/sites.md, Limits). Hence 100 calls a
    // client per repetition, and no repetition after one with failures.
    const std::string across = "throughput across spaces, 4 client(s), 64 B: kr → jp, the link over TCP and over UDP";
    if (tcp_linked && wanted(across)) {
      const int across_per = 100;
      std::vector<std::unique_ptr<urs::planet::Client>> planets;
      for (int c = 0; c < 4; ++c) planets.push_back(connect(space.port()));
      std::mutex failure_mutex;
      std::string first_failure;
      auto rate_of = [&](const std::string& service, int& failed) {
        std::atomic<int> failures{0};
        const double rate = urs::bench::throughput(4, across_per, [&](int c) {
          return [&, cl = planets[static_cast<size_t>(c)].get()] {
            const urs::planet::CallResult r = cl->call(service, "echo", echo_payload, 10s);
            if (r.ok()) return;
            ++failures;
            std::lock_guard lock(failure_mutex);
            if (first_failure.empty()) {
              first_failure = service + ": " + std::string(urs::planet::status_name(r.status)) + ": " + r.message;
            }
          };
        });
        failed += failures;
        return rate * (1.0 - static_cast<double>(failures) / (4.0 * across_per));
      };
      std::vector<double> tcp, udp, share;
      int tcp_failed = 0, udp_failed = 0;
      for (int r = 0; r < repetitions; ++r) {
        udp.push_back(rate_of("jp/rt.diag", udp_failed));
        tcp.push_back(rate_of("jp-tcp/rt.diag", tcp_failed));
        share.push_back(tcp.back() / udp.back());
        if (tcp_failed + udp_failed > 0) break;  // each failed call cost its 10 s deadline
      }
      const double median_share = urs::bench::percentile(share, 0.5);
      char value[400];
      std::snprintf(value, sizeof(value), "TCP %.0f calls/s, UDP %.0f; TCP/UDP %.2f (%.2f – %.2f)%s (goal >= 0.83: %s)",
                    urs::bench::percentile(tcp, 0.5), urs::bench::percentile(udp, 0.5), median_share,
                    *std::min_element(share.begin(), share.end()), *std::max_element(share.begin(), share.end()),
                    tcp_failed + udp_failed == 0
                        ? ""
                        : ("; calls failed: " + std::to_string(tcp_failed) + " over TCP, " +
                           std::to_string(udp_failed) + " over UDP, the first " + first_failure)
                              .c_str(),
                    median_share >= 1 / 1.2 && tcp_failed == 0 ? "met" : "missed");
      extras.push_back({across, value});
    }

    // A sustained stream of 921,600-byte images, in space and across spaces.
    for (const std::string service : {"rt.diag", "jp/rt.diag"}) {
      if (!wanted("921,600-byte stream through " + service)) continue;
      const auto t0 = std::chrono::steady_clock::now();
      const auto duration = quick ? 1s : 5s;
      int frames = 0, lost = 0;
      while (std::chrono::steady_clock::now() - t0 < duration) {
        (client->call(service, "blob", blob_payload, 2s).ok() ? frames : lost)++;
      }
      char value[96];
      std::snprintf(value, sizeof(value), "%.1f frames/s, %d lost (goal 30/s, none lost)",
                    frames / std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), lost);
      extras.push_back({"921,600-byte stream through " + service, value});
    }

    // Discovery across spaces: a new RTC in jp until it answers from kr.
    if (wanted("discovery")) {
      std::vector<double> discoveries;
      for (int i = 0; i < (quick ? 1 : 5); ++i) {
        const std::string host = "disc" + std::to_string(i);
        const auto t0 = std::chrono::steady_clock::now();
        auto newcomer =
            start_with_config(dir, host, "components:\n  - type: Diagnostic\n",
                              {URS_RTC_MANAGER_BIN, "--space", "jp", "--naming", naming.address(), "--host", host});
        const std::string service = "jp/Diagnostic0@" + host;
        if (!urs::test::wait_until([&] { return client->call(service, "echo", echo_payload, 200ms).ok(); }, 30s)) {
          throw std::runtime_error(service + " never became callable: " + bridge_jp->log() + bridge_kr->log());
        }
        discoveries.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
      }
      char found[96];
      std::snprintf(found, sizeof(found), "median %.0f ms, max %.0f ms (goal median <= 300 ms, p99 <= 1500 ms)",
                    urs::bench::percentile(discoveries, 0.5), urs::bench::percentile(discoveries, 1.0));
      extras.push_back({"discovery: RTC bound in jp until callable from kr (bridge polls naming every 100 ms)", found});
    }

    if (wanted("RSS bridge-kr offering 1,000 services over DDS")) {  // and the other RSS lines
      extras.push_back(
          {"RSS urs-bridge in the space (1 service each way)", std::to_string(rss_kib(bridge->pid())) + " KiB"});
      extras.push_back({"RSS bridge-kr idle (1 service offered)", std::to_string(rss_kib(bridge_kr->pid())) + " KiB"});

      // Memory idle, then with 1,000 registered services.
      extras.push_back({"RSS urs-camus-server idle", std::to_string(rss_kib(space.server().pid())) + " KiB"});
      extras.push_back({"RSS urs-sam idle (1 agent)", std::to_string(rss_kib(space.sam().pid())) + " KiB"});
      {
        auto provider = connect(space.port(), urs::planet::SAM);
        const std::string desc = urs::schema::descriptor_set_for(*URS::Diagnostic_echo_Request::descriptor()->file());
        std::atomic<int> done{0};
        for (int i = 0; i < 1000; ++i) {
          urs::camus::RegisterRequest reg;
          reg.mutable_service()->set_name("svc" + std::to_string(i));
          reg.mutable_service()->set_interface("URS.Diagnostic");
          reg.set_descriptor_set(desc);
          provider->register_service(reg, [&](urs::planet::CallResult r) {
            expect_ok(r, "register");
            ++done;
          });
        }
        if (!urs::test::wait_until([&] { return done.load() == 1000; }, 30s))
          throw std::runtime_error("registrations did not complete");
        extras.push_back(
            {"RSS urs-camus-server, 1,000 services", std::to_string(rss_kib(space.server().pid())) + " KiB"});
        // bridge-kr offers them all to the other spaces: each described by the registry and
        // announced on DDS with its interface description (bridge-jp imports only kr/diag).
        std::this_thread::sleep_for(quick ? 3s : 6s);
        extras.push_back({"RSS bridge-kr offering 1,000 services over DDS",
                          std::to_string(rss_kib(bridge_kr->pid())) + " KiB (goal <= 65536 KiB)"});
      }
    }

    // Recovery: kill -9 the server, restart it on the same port, until the SAM's agent answers.
    if (wanted("recovery")) {
      std::vector<double> recoveries;
      for (int r = 0; r < (quick ? 1 : 5); ++r) {
        int port = space.port();
        space.server().kill9();
        auto t0 = std::chrono::steady_clock::now();
        space.start_server(port);
        auto probe = connect(space.port());
        URS::Diagnostic_echo_Request ping;
        if (!urs::test::wait_until([&] { return probe->call("diag", "echo", ping.SerializeAsString(), 200ms).ok(); },
                                   10s)) {
          throw std::runtime_error("diag not callable after a server restart");
        }
        recoveries.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
      }
      char value[64];
      std::snprintf(value, sizeof(value), "median %.0f ms, max %.0f ms (goal <= 1000 ms)",
                    urs::bench::percentile(recoveries, 0.5), urs::bench::percentile(recoveries, 1.0));
      extras.push_back({"recovery after server kill -9 until SA callable", value});
    }

  } catch (const std::exception& e) {
    std::cerr << "urs-bench: " << e.what() << "\n";
    std::filesystem::remove_all(dir);
    return 1;
  }
  std::filesystem::remove_all(dir);

  const urs::bench::Report out = urs::bench::report(rows, extras, quick);
  std::cout << out.markdown;
  if (!json_path.empty()) std::ofstream(json_path) << out.json;
  if (!markdown_path.empty()) std::ofstream(markdown_path) << out.markdown;
  return 0;
}
