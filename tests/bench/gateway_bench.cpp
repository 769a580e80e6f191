// urs-gateway-bench: poses through urs-gateway to many WebSocket clients (docs/dashboard.md,
// docs/performance.md). It starts a CAMUS space whose SAM hosts a robot and its localizer
// (--rate Hz) in a DDS domain of its own, and urs-gateway following the robot in that domain;
// then N clients (default 10, as many dashboards or Foxglove windows) subscribe to /poses and
// measure, for every pose, the time from the localizer's sample (the pose's stamp) to its arrival,
// while the gateway's resident memory is sampled every second.
//
//   urs-gateway-bench [--clients N] [--seconds S] [--rate HZ] [--quick] [--json FILE] [--markdown FILE]
//
// Goals (issue of the gateway): >= 20 Hz delivered to every client, p99 <= 100 ms, memory flat.
// It reports what it measured; --quick (the test suite's smoke run) fails only if a client got
// nothing or was dropped.

#include <atomic>
#include <boost/asio/ip/tcp.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/websocket.hpp>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <mutex>
#include <sstream>
#include <thread>

#include "bench_stats.hpp"
#include "dds_domain.hpp"
#include "process.hpp"

namespace beast = boost::beast;
namespace websocket = beast::websocket;
namespace net = boost::asio;
using tcp = net::ip::tcp;
using namespace std::chrono_literals;

namespace {

double unix_now() { return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count(); }

// VmRSS of a process, KiB (0 if unreadable).
long rss_kib(pid_t pid) {
  std::ifstream status("/proc/" + std::to_string(pid) + "/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.rfind("VmRSS:", 0) == 0) return std::strtol(line.c_str() + 6, nullptr, 10);
  }
  return 0;
}

struct ClientResult {
  std::atomic<bool> receiving{false};  // a first pose arrived
  std::vector<double> latencies_ms;
  uint64_t poses = 0;
  bool dropped = false;
  std::string error;
};

// One client: subscribes to /poses and times every pose until `stop`.
void run_client(uint16_t port, const std::atomic<bool>& stop, const std::atomic<bool>& measuring, ClientResult& out) {
  try {
    net::io_context ioc;
    websocket::stream<tcp::socket> ws(ioc);
    ws.next_layer().connect(tcp::endpoint(net::ip::make_address("127.0.0.1"), port));
    ws.set_option(websocket::stream_base::decorator([](websocket::request_type& req) {
      req.set(beast::http::field::sec_websocket_protocol, "foxglove.websocket.v1");
    }));
    ws.handshake("127.0.0.1:" + std::to_string(port), "/");
    beast::flat_buffer buffer;
    // The /poses channel's id from the advertisement.
    long channel = -1;
    while (channel < 0) {
      buffer.consume(buffer.size());
      ws.read(buffer);
      const std::string text = beast::buffers_to_string(buffer.data());
      const auto topic = text.find("\"topic\":\"/poses\"");
      if (ws.got_text() && topic != std::string::npos) {
        const auto id = text.rfind("\"id\":", topic);
        channel = std::strtol(text.c_str() + id + 5, nullptr, 10);
      }
    }
    const std::string subscribe =
        "{\"op\":\"subscribe\",\"subscriptions\":[{\"id\":1,\"channelId\":" + std::to_string(channel) + "}]}";
    ws.write(net::buffer(subscribe));
    beast::get_lowest_layer(ws).non_blocking(false);
    while (!stop) {
      buffer.consume(buffer.size());
      beast::error_code error;
      ws.read(buffer, error);
      if (error) {
        out.dropped = !stop;
        if (!stop) out.error = error.message();
        return;
      }
      if (ws.got_text()) continue;
      const double arrived = unix_now();
      const std::string message = beast::buffers_to_string(buffer.data());
      const auto stamp = message.find("\"stamp\":");
      if (message.size() < 13 || message[0] != 0x01 || stamp == std::string::npos) continue;
      out.receiving = true;
      if (!measuring) continue;
      ++out.poses;
      out.latencies_ms.push_back((arrived - std::strtod(message.c_str() + stamp + 8, nullptr)) * 1000.0);
    }
    beast::error_code ignored;
    ws.close(websocket::close_code::normal, ignored);
  } catch (const std::exception& e) {
    out.dropped = true;
    out.error = e.what();
  }
}

}  // namespace

int main(int argc, char** argv) {
  int clients = 10;
  double seconds = 60;
  double rate = 50;
  bool quick = false;
  std::string json_path, markdown_path;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--help" || a == "-h") {
      std::cout << "usage: urs-gateway-bench [--clients N] [--seconds S] [--rate HZ] [--quick] [--json FILE] "
                   "[--markdown FILE]\n"
                   "  --clients N      WebSocket clients subscribed to /poses (default 10)\n"
                   "  --seconds S      how long poses are timed (default 60; deploy/bench.sh: 600)\n"
                   "  --rate HZ        the localizer's rate (default 50, at most 100)\n"
                   "  --quick          at most 8 s; fails only if a client got nothing or was dropped\n"
                   "  --json FILE, --markdown FILE   the figures, also written there\n"
                   "Reports per client the poses delivered (Hz), the latency from the localizer's sample to\n"
                   "the client (median, p99, max) and the gateway's resident memory (means of the first and last "
                   "tenths of the run).\n";
      return 0;
    }
    auto next = [&]() -> std::string {
      if (i + 1 >= argc) throw std::invalid_argument(a + " needs a value");
      return argv[++i];
    };
    try {
      if (a == "--clients")
        clients = std::stoi(next());
      else if (a == "--seconds")
        seconds = std::stod(next());
      else if (a == "--rate")
        rate = std::stod(next());
      else if (a == "--quick")
        quick = true;
      else if (a == "--json")
        json_path = next();
      else if (a == "--markdown")
        markdown_path = next();
      else
        throw std::invalid_argument("unknown argument " + a);
    } catch (const std::exception& e) {
      std::cerr << "urs-gateway-bench: " << e.what()
                << "\nusage: urs-gateway-bench [--clients N] [--seconds S] [--rate HZ] [--quick] [--json FILE] "
                   "[--markdown FILE]\n";
      return 2;
    }
  }
  if (quick) seconds = std::min(seconds, 8.0);
  if (clients < 1 || clients > 1000 || seconds <= 0 || rate <= 0 || rate > 100) {
    std::cerr << "urs-gateway-bench: --clients 1..1000, --seconds > 0, --rate 0..100\n";
    return 2;
  }

  urs::test::DdsDomains domains(1);
  const std::string dir = urs::test::make_temp_dir("gateway-bench");
  std::ofstream(dir + "/sam.yaml") << "agents:\n"
                                      "  - name: robot1.navigation\n    type: robot\n"
                                      "    params: {name: robot1, prefix: robot1.navigation, domain: "
                                   << domains[0]
                                   << ", x: 1.5, y: 1.0}\n"
                                      "  - name: robot1.localizer\n    type: localizer\n"
                                      "    params: {robot: robot1, prefix: loc1, domain: "
                                   << domains[0] << ", rate: " << rate << "}\n";
  urs::test::Process server({URS_SERVER_BIN, "--space", "bench", "--listen", "127.0.0.1:0", "--port-file",
                             dir + "/server.port", "--log-level", "warn"},
                            dir + "/server.log");
  if (!urs::test::wait_until([&] { return std::filesystem::exists(dir + "/server.port"); }, 15s)) {
    std::cerr << "urs-gateway-bench: urs-camus-server did not start:\n" << server.log();
    return 1;
  }
  const std::string camus = "127.0.0.1:" + urs::test::read_text(dir + "/server.port");
  urs::test::Process sam(
      {URS_SAM_BIN, "--space", "bench", "--server", camus, "--config", dir + "/sam.yaml", "--log-level", "warn"},
      dir + "/sam.log");
  urs::test::Process gateway({URS_GATEWAY_BIN, "--space", "bench", "--server", camus, "--listen", "127.0.0.1:0",
                              "--port-file", dir + "/gateway.port", "--anonymous", "viewer", "--devices-domain",
                              std::to_string(domains[0]), "--robots", "robot1", "--log-level", "warn"},
                             dir + "/gateway.log");
  if (!urs::test::wait_until([&] { return std::filesystem::exists(dir + "/gateway.port"); }, 20s)) {
    std::cerr << "urs-gateway-bench: urs-gateway did not start:\n" << gateway.log();
    return 1;
  }
  const auto port = static_cast<uint16_t>(std::stoi(urs::test::read_text(dir + "/gateway.port")));

  std::atomic<bool> stop{false};
  std::atomic<bool> measuring{false};
  std::vector<ClientResult> results(static_cast<std::size_t>(clients));
  std::vector<std::thread> threads;
  for (int i = 0; i < clients; ++i) {
    threads.emplace_back([&, i] { run_client(port, stop, measuring, results[static_cast<std::size_t>(i)]); });
  }
  // Until every client receives poses (discovery in the devices' domain), then measure.
  const bool ready = urs::test::wait_until(
      [&] {
        return std::all_of(results.begin(), results.end(), [](const ClientResult& r) { return r.receiving.load(); });
      },
      30s);
  if (!ready) std::cerr << "urs-gateway-bench: not every client received a pose within 30 s; measuring anyway\n";
  measuring = true;
  std::vector<long> rss;
  const auto started = std::chrono::steady_clock::now();
  const auto until =
      started + std::chrono::duration_cast<std::chrono::steady_clock::duration>(std::chrono::duration<double>(seconds));
  while (std::chrono::steady_clock::now() < until) {
    rss.push_back(rss_kib(gateway.pid()));
    std::this_thread::sleep_for(1s);
  }
  measuring = false;
  const double measured = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  rss.push_back(rss_kib(gateway.pid()));
  stop = true;
  gateway.signal(SIGTERM);  // ends every client's connection
  for (auto& thread : threads) thread.join();
  gateway.wait(10s);

  std::vector<double> all;
  double min_rate = 1e9, sum_rate = 0;
  int dropped = 0;
  for (const auto& r : results) {
    all.insert(all.end(), r.latencies_ms.begin(), r.latencies_ms.end());
    const double hz = static_cast<double>(r.poses) / measured;
    min_rate = std::min(min_rate, hz);
    sum_rate += hz;
    if (r.dropped) {
      ++dropped;
      std::cerr << "urs-gateway-bench: a client was dropped: " << r.error << "\n";
    }
  }
  const double median = urs::bench::percentile(all, 0.5), p99 = urs::bench::percentile(all, 0.99);
  const double max_latency = all.empty() ? 0 : *std::max_element(all.begin(), all.end());
  // Memory: the first and last tenth of the run, averaged, and the peak.
  const std::size_t tenth = std::max<std::size_t>(1, rss.size() / 10);
  auto mean = [](auto begin, auto end) {
    double sum = 0;
    for (auto it = begin; it != end; ++it) sum += static_cast<double>(*it);
    return end > begin ? sum / static_cast<double>(end - begin) : 0.0;
  };
  const double rss_start = mean(rss.begin(), rss.begin() + static_cast<long>(tenth));
  const double rss_end = mean(rss.end() - static_cast<long>(tenth), rss.end());
  const long rss_peak = rss.empty() ? 0 : *std::max_element(rss.begin(), rss.end());

  std::ostringstream table;
  table << "| clients | run | localizer | delivered per client (min / mean) | latency median | p99 | max | gateway RSS "
           "first tenth → last tenth (peak) | dropped |\n"
        << "|---|---|---|---|---|---|---|---|---|\n";
  char line[512];
  std::snprintf(
      line, sizeof line,
      "| %d | %.0f s | %.0f Hz | %.1f / %.1f Hz | %.1f ms | %.1f ms | %.1f ms | %.1f → %.1f MiB (%.1f MiB) | %d |\n",
      clients, measured, rate, min_rate, sum_rate / clients, median, p99, max_latency, rss_start / 1024, rss_end / 1024,
      static_cast<double>(rss_peak) / 1024, dropped);
  table << line;
  std::cout << table.str();
  std::cout << "urs-gateway-bench: " << all.size() << " poses timed; goals >= 20 Hz per client, p99 <= 100 ms, "
            << "memory flat\n";
  if (!json_path.empty()) {
    std::ofstream(json_path) << "{\"clients\":" << clients << ",\"seconds\":" << measured << ",\"rate_hz\":" << rate
                             << ",\"min_client_hz\":" << min_rate << ",\"mean_client_hz\":" << sum_rate / clients
                             << ",\"median_ms\":" << median << ",\"p99_ms\":" << p99 << ",\"max_ms\":" << max_latency
                             << ",\"rss_start_kib\":" << rss_start << ",\"rss_end_kib\":" << rss_end
                             << ",\"rss_peak_kib\":" << rss_peak << ",\"dropped\":" << dropped << "}\n";
  }
  if (!markdown_path.empty()) std::ofstream(markdown_path) << table.str();
  std::filesystem::remove_all(dir);
  if (all.empty() || dropped > 0 || min_rate <= 0) {
    std::cerr << "urs-gateway-bench: no measurement (a client got no pose or was dropped)\n";
    return 1;
  }
  return 0;
}
