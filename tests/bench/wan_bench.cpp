// urs-wan-bench: a cross-space call over the link over TCP through the emulated internet
// (tests/e2e/sites), next to the raw TCP round trip of the same path, measured in turns. Run in
// one of the two sites by tests/bench/wan_bench.sh, which sets the sites up and starts the programs.
//
//   urs-wan-bench --path TEXT (kr → jp | jp → kr) [--quick] [--pin] [--json FILE] [--markdown FILE]
//   kr → jp, in the connecting site:
//     --server HOST:PORT  its urs-camus-server; the calls are made there, as a user's are
//     --service NAME      the listening site's Diagnostic as imported there (jp/rt.Diagnostic0)
//     --raw HOST:PORT     a `tcp-rtt --serve` in the listening site behind a port its router
//                         forwards, as the link's: the path's own round trip
//   jp → kr, in the listening site:
//     --naming HOST:PORT  its naming service
//     --rtc PATH          the connecting site's Diagnostic bound there as an RTC
//                         (jp-bridge.host_cxt/kr_diag.rtc), called through static stubs
//     --raw-accept PORT   waits for 4 connections on PORT (forwarded by its router) from a
//                         `tcp-rtt --serve-over` in the connecting site, which answers over
//                         them: a round trip over connections opened from there, as the link's
//     --ready-file PATH   written once PORT listens
// --path: what the rows call the path (e.g. "40 ms each way, 0 % loss").
// The raw round trips are raw_tcp.hpp's, as `tcp-rtt --connect` makes them, but in this process,
// so that each repetition of a row and of its baseline run in turns (bench_stats.hpp). Rows: 64 B
// (goal: <= 1.2x the raw round trip) and a 921,600-byte reply, each against the raw round trip;
// throughput with 4 clients against 4 raw connections, in turns. Same table and JSON as urs-bench
// (report.hpp). Numbers are reported, never asserted.

#include <poll.h>
#include <signal.h>

#include <atomic>
#include <fstream>
#include <iostream>
#include <memory>

#include "Diagnostic.pb.h"
#include "bench_stats.hpp"
#include "corba_stub.hpp"
#include "pinning.hpp"
#include "raw_tcp.hpp"
#include "report.hpp"
#include "rt_provider.hpp"
#include "urs/planet/client.hpp"
#include "urs/util/cli.hpp"

namespace {

using namespace std::chrono_literals;
constexpr int kClients = 4;
constexpr uint32_t kBigReply = 921600;

std::pair<std::string, uint16_t> host_port(const std::string& text) {
  const auto colon = text.rfind(':');
  if (colon == std::string::npos) throw std::runtime_error("'" + text + "' is not HOST:PORT");
  return {text.substr(0, colon), static_cast<uint16_t>(std::stoi(text.substr(colon + 1)))};
}

// One direction's callers: a call per client (big: a 921,600-byte reply, else a 64-byte echo),
// each throwing std::runtime_error when it fails; and a raw connection per client.
struct Direction {
  std::string name;       // "kr → jp"
  std::string link_path;  // the rows' names
  std::string raw_path;
  std::vector<std::function<void(bool big)>> calls;
  std::vector<int> raw_fds;
};

// kr → jp: Planet clients of the connecting site's server, and connections to a `tcp-rtt --serve`.
class FromConnectingSite {
 public:
  FromConnectingSite(const std::string& server, const std::string& service, const std::string& raw) {
    URS::Diagnostic_echo_Request echo;
    echo.set_text(std::string(64, 'x'));
    URS::Diagnostic_blob_Request blob;
    blob.set_size(kBigReply);
    echo_ = echo.SerializeAsString();
    blob_ = blob.SerializeAsString();
    const auto [raw_host, raw_port] = host_port(raw);
    urs::planet::ClientOptions options;
    std::tie(options.host, options.port) = host_port(server);
    options.peer_name = "wan-bench";
    direction_.name = "kr → jp";
    direction_.link_path = "cross-space over the TCP link, kr client→server→bridge-kr→TCP→bridge-jp→RTC";
    direction_.raw_path = "raw TCP round trip through both NATs (tcp-rtt)";
    for (int c = 0; c < kClients; ++c) {
      auto client = std::make_unique<urs::planet::Client>(options);
      client->start();
      if (!client->wait_connected(10s)) {
        throw std::runtime_error("cannot connect to " + server + ": " + client->last_error());
      }
      direction_.calls.push_back([this, service, cl = client.get()](bool big) {
        const urs::planet::CallResult r = cl->call(service, big ? "blob" : "echo", big ? blob_ : echo_, 30s);
        if (!r.ok()) {
          throw std::runtime_error(service + ": " + std::string(urs::planet::status_name(r.status)) + ": " + r.message);
        }
      });
      clients_.push_back(std::move(client));
      direction_.raw_fds.push_back(urs::bench::connect_to(raw_host, raw_port));
    }
  }
  ~FromConnectingSite() {
    for (const int fd : direction_.raw_fds) ::close(fd);
  }
  FromConnectingSite(const FromConnectingSite&) = delete;
  FromConnectingSite& operator=(const FromConnectingSite&) = delete;
  Direction& direction() { return direction_; }

 private:
  std::string echo_, blob_;
  std::vector<std::unique_ptr<urs::planet::Client>> clients_;
  Direction direction_;
};

// jp → kr: static stubs of the RTC standing for kr's Diagnostic, and the connections a
// `tcp-rtt --serve-over` in the connecting site opens to `port`.
class FromListeningSite {
 public:
  FromListeningSite(const std::string& naming, const std::string& rtc, uint16_t port, const std::string& ready_file)
      : orb_(orb_options()), names_(orb_, naming) {
    direction_.name = "jp → kr";
    direction_.link_path = "cross-space over the TCP link, jp stub→bridge-jp→TCP→bridge-kr→server→SAM→SA";
    direction_.raw_path = "raw TCP round trip over connections from kr's site (tcp-rtt --serve-over)";
    for (int c = 0; c < kClients; ++c) {
      CORBA::Object_var object = urs::bench::provider(orb_, names_, rtc, "diagnostic");
      stubs_.push_back(std::make_unique<urs::bench::DiagnosticStub>(object));
      // CORBA's exceptions are no std::exception: said as one (what the bridge refused, e.g. TRANSIENT).
      direction_.calls.push_back([stub = stubs_.back().get()](bool big) {
        try {
          if (big) {
            stub->blob(kBigReply);
          } else {
            stub->echo(std::string(64, 'x'));
          }
        } catch (const CORBA::Exception& e) {
          throw std::runtime_error(std::string(big ? "blob" : "echo") + " through the stub: CORBA::" + e._name());
        }
      });
    }
    accept_raw(port, ready_file);
  }
  ~FromListeningSite() {
    for (const int fd : direction_.raw_fds) ::close(fd);
  }
  FromListeningSite(const FromListeningSite&) = delete;
  FromListeningSite& operator=(const FromListeningSite&) = delete;
  Direction& direction() { return direction_; }

 private:
  static urs::rtc::OrbOptions orb_options() {
    urs::rtc::OrbOptions options;
    options.call_timeout = 30s;  // a 921,600-byte reply over a lossy 80 ms path
    return options;
  }
  void accept_raw(uint16_t port, const std::string& ready_file) {
    const int listener = ::socket(AF_INET, SOCK_STREAM, 0);
    int one = 1;
    ::setsockopt(listener, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
    sockaddr_in address{};
    address.sin_family = AF_INET;
    address.sin_port = htons(port);
    if (::bind(listener, reinterpret_cast<sockaddr*>(&address), sizeof address) != 0 || ::listen(listener, 8) != 0) {
      ::close(listener);
      throw std::runtime_error("cannot listen on port " + std::to_string(port) + ": " + std::strerror(errno));
    }
    if (!ready_file.empty()) std::ofstream(ready_file) << "ready\n";
    while (direction_.raw_fds.size() < kClients) {
      pollfd waiting{listener, POLLIN, 0};
      if (::poll(&waiting, 1, 30000) != 1) {
        ::close(listener);
        throw std::runtime_error("no tcp-rtt --serve-over connected to port " + std::to_string(port) +
                                 " within 30 s (" + std::to_string(direction_.raw_fds.size()) + " of " +
                                 std::to_string(kClients) + ")");
      }
      const int fd = ::accept(listener, nullptr, nullptr);
      if (fd < 0) continue;
      ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
      direction_.raw_fds.push_back(fd);
    }
    ::close(listener);
  }

  urs::rtc::Orb orb_;
  urs::rtc::NamingClient names_;
  std::vector<std::unique_ptr<urs::bench::DiagnosticStub>> stubs_;
  Direction direction_;
};

// The rows of one direction: 64 B and 921,600 B in turns with the raw round trip, then throughput.
// A part whose call fails is said in `extras` ("not measured: ...") and the next part measured.
void measure(Direction& d, const std::string& path, bool quick, std::vector<urs::bench::Row>& rows,
             std::vector<urs::bench::Extra>& extras) {
  // Each call crosses an 80 ms path: tens of calls per repetition, not thousands.
  const int repetitions = quick ? 1 : 5;
  const int per_client = quick ? 5 : 20;
  const std::string raw_row = "WAN " + path + ": " + d.raw_path;
  const std::string link_row = "WAN " + path + ": " + d.link_path;
  const std::string raw_small(64, 'x'), raw_big = urs::bench::blob_request(kBigReply);
  std::string reply;
  int group = 0;
  for (const bool big : {false, true}) {
    const std::string size = big ? "921,600 B" : "64 B";
    const std::string& raw_request = big ? raw_big : raw_small;
    try {
      const std::vector<urs::bench::Summary> measured = urs::bench::measure_interleaved(
          {[&] { urs::bench::round_trip(d.raw_fds[0], raw_request, reply); }, [&] { d.calls[0](big); }}, big ? 2 : 5,
          big ? (quick ? 3 : 8) : (quick ? 10 : 40), repetitions);
      ++group;
      rows.push_back({raw_row, size, measured[0], "", 0, group});
      // The goal is at 64 B; a 921,600-byte reply's ratio is shown without one.
      rows.push_back({link_row, size, measured[1], raw_row + "|" + size, big ? 0 : 1.2, group});
    } catch (const std::exception& e) {
      extras.push_back({link_row + ", " + size, std::string("not measured: ") + e.what()});
    }
  }

  // Throughput, 4 clients, 64 B: 4 callers through the link's one connection, and 4 raw
  // connections, in turns. A failed call is counted, not thrown: it runs on a thread of throughput().
  const std::string label = "WAN " + path + ": throughput, 4 client(s), 64 B, " + d.name + ": the TCP link and raw TCP";
  std::atomic<int> failed{0};
  std::vector<double> link_rate, raw_rate, share;
  for (int r = 0; r < repetitions; ++r) {
    link_rate.push_back(urs::bench::throughput(kClients, per_client, [&](int c) {
      return [&, c] {
        try {
          d.calls[static_cast<size_t>(c)](false);
        } catch (const std::exception&) {
          ++failed;
        }
      };
    }));
    raw_rate.push_back(urs::bench::throughput(kClients, per_client, [&](int c) {
      return [&, c, mine = std::string()]() mutable {
        const int fd = d.raw_fds[static_cast<size_t>(c)];
        if (!urs::bench::send_message(fd, raw_small.data(), static_cast<uint32_t>(raw_small.size())) ||
            !urs::bench::recv_message(fd, mine)) {
          ++failed;
        }
      };
    }));
    if (failed > 0) {
      extras.push_back({label, "not measured: " + std::to_string(failed.load()) + " calls failed"});
      return;
    }
    share.push_back(link_rate.back() / raw_rate.back());
  }
  const double median_share = urs::bench::percentile(share, 0.5);
  char value[240];
  std::snprintf(value, sizeof(value),
                "TCP link %.1f calls/s, raw TCP %.1f; link/raw %.2f (%.2f – %.2f) (goal >= 0.83: %s)",
                urs::bench::percentile(link_rate, 0.5), urs::bench::percentile(raw_rate, 0.5), median_share,
                *std::min_element(share.begin(), share.end()), *std::max_element(share.begin(), share.end()),
                median_share >= 1 / 1.2 ? "met" : "missed");
  extras.push_back({label, value});
}

[[noreturn]] void usage(const std::string& why) {
  std::cerr << "urs-wan-bench: " << why
            << "\nusage: urs-wan-bench --path TEXT [--quick] [--pin] [--json FILE] [--markdown FILE]\n"
               "         (--server HOST:PORT --service NAME --raw HOST:PORT\n"
               "          | --naming HOST:PORT --rtc PATH --raw-accept PORT [--ready-file PATH])\n";
  std::exit(2);
}

}  // namespace

int main(int argc, char** argv) {
  std::string server, service, raw, naming, rtc, raw_accept, ready_file, path, json_path, markdown_path;
  bool quick = false;
  for (int i = 1; i < argc; ++i) {
    const std::string flag = argv[i];
    if (flag == "--quick") {
      quick = true;
      continue;
    }
    if (flag == "--pin") {
      urs::bench::pinning() = true;
      continue;
    }
    if (i + 1 >= argc) usage(flag + " needs a value");
    const std::string value = argv[++i];
    if (flag == "--server")
      server = value;
    else if (flag == "--service")
      service = value;
    else if (flag == "--raw")
      raw = value;
    else if (flag == "--naming")
      naming = value;
    else if (flag == "--rtc")
      rtc = value;
    else if (flag == "--raw-accept")
      raw_accept = value;
    else if (flag == "--ready-file")
      ready_file = value;
    else if (flag == "--path")
      path = value;
    else if (flag == "--json")
      json_path = value;
    else if (flag == "--markdown")
      markdown_path = value;
    else
      usage("unknown flag " + flag);
  }
  const bool from_connecting = !server.empty() && !service.empty() && !raw.empty();
  const bool from_listening = !naming.empty() && !rtc.empty() && !raw_accept.empty();
  if (path.empty() || from_connecting == from_listening) {
    usage("--path, and either --server, --service and --raw or --naming, --rtc and --raw-accept");
  }
  signal(SIGPIPE, SIG_IGN);
  if (urs::bench::pinning()) urs::bench::pin_this_thread(urs::bench::kClientCpu);  // before any thread starts
  urs::util::init_logging("urs-wan-bench", "warn");                                // stderr; stdout the report

  std::vector<urs::bench::Row> rows;
  std::vector<urs::bench::Extra> extras;
  try {
    if (from_connecting) {
      FromConnectingSite site(server, service, raw);
      measure(site.direction(), path, quick, rows, extras);
    } else {
      FromListeningSite site(naming, rtc, static_cast<uint16_t>(std::stoi(raw_accept)), ready_file);
      measure(site.direction(), path, quick, rows, extras);
    }
  } catch (const std::exception& e) {
    std::cerr << "urs-wan-bench: " << e.what() << "\n";
    return 1;
  }
  const urs::bench::Report out = urs::bench::report(rows, extras, quick);
  std::cout << out.markdown;
  if (!json_path.empty()) std::ofstream(json_path) << out.json;
  if (!markdown_path.empty()) std::ofstream(markdown_path) << out.markdown;
  return 0;
}
