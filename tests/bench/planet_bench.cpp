// urs-bench: URSLink paths side by side with the native paths they add to, measured in one run.
//
//   urs-bench [--quick] [--json FILE] [--markdown FILE]
//
// Rows: raw TCP echo (the floor) and a Planet call client → urs-camus-server → urs-sam → agent,
// for a 64-byte and a 921,600-byte payload; throughput with 1 and 4 clients; recovery after a
// server kill -9; resident memory of the server and SAM idle and with 1,000 services.
// Every process is real and runs on 127.0.0.1. Numbers are reported, never asserted.

#include <arpa/inet.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/uio.h>
#include <unistd.h>

#include <atomic>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>
#include <thread>

#include "Diagnostic.pb.h"
#include "bench_stats.hpp"
#include "camus.pb.h"
#include "process.hpp"
#include "urs/planet/client.hpp"
#include "urs/schema/schema.hpp"
#include "urs/util/cli.hpp"

namespace {

using namespace std::chrono_literals;
using urs::bench::Row;
using urs::bench::Summary;

// ---- raw TCP echo: length-prefixed messages echoed by a thread ----------------------------

bool send_all(int fd, const char* data, size_t n) {
  while (n > 0) {
    ssize_t w = ::send(fd, data, n, MSG_NOSIGNAL);
    if (w <= 0) return false;
    data += w;
    n -= static_cast<size_t>(w);
  }
  return true;
}
// Length prefix and body in one writev, so that a message is one segment (the floor must not be
// inflated by an extra wake-up per message).
bool send_message(int fd, const char* data, uint32_t n) {
  uint32_t prefix = htonl(n);
  iovec parts[2] = {{&prefix, 4}, {const_cast<char*>(data), n}};
  ssize_t w = ::writev(fd, parts, 2);
  if (w <= 0) return false;
  size_t sent = static_cast<size_t>(w);
  if (sent < 4) {  // a partial write: finish with plain sends
    if (!send_all(fd, reinterpret_cast<char*>(&prefix) + sent, 4 - sent)) return false;
    sent = 4;
  }
  return send_all(fd, data + (sent - 4), n - (sent - 4));
}
bool recv_all(int fd, char* data, size_t n) {
  while (n > 0) {
    ssize_t r = ::recv(fd, data, n, 0);
    if (r <= 0) return false;
    data += r;
    n -= static_cast<size_t>(r);
  }
  return true;
}
void no_delay(int fd) {
  int one = 1;
  setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof(one));
}

class RawEcho {
 public:
  RawEcho() {
    listener_ = socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    bind(listener_, reinterpret_cast<sockaddr*>(&addr), sizeof(addr));
    listen(listener_, 8);
    socklen_t len = sizeof(addr);
    getsockname(listener_, reinterpret_cast<sockaddr*>(&addr), &len);
    port_ = ntohs(addr.sin_port);
    thread_ = std::thread([this] { serve(); });
  }
  ~RawEcho() {
    shutdown(listener_, SHUT_RDWR);
    close(listener_);
    thread_.join();
  }
  int connect_client() const {
    int fd = socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    addr.sin_port = htons(port_);
    if (connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)) != 0) throw std::runtime_error("connect");
    no_delay(fd);
    return fd;
  }
  static void round_trip(int fd, std::string& buffer) {
    uint32_t n = 0;
    if (!send_message(fd, buffer.data(), static_cast<uint32_t>(buffer.size())) ||
        !recv_all(fd, reinterpret_cast<char*>(&n), 4) || !recv_all(fd, buffer.data(), ntohl(n))) {
      throw std::runtime_error("raw echo failed");
    }
  }

 private:
  void serve() {
    std::vector<std::thread> workers;
    for (;;) {
      int fd = accept(listener_, nullptr, nullptr);
      if (fd < 0) break;
      no_delay(fd);
      workers.emplace_back([fd] {
        std::string buffer;
        uint32_t n = 0;
        while (recv_all(fd, reinterpret_cast<char*>(&n), 4)) {
          buffer.resize(ntohl(n));
          if (!recv_all(fd, buffer.data(), buffer.size())) break;
          if (!send_message(fd, buffer.data(), static_cast<uint32_t>(buffer.size()))) break;
        }
        close(fd);
      });
    }
    for (auto& w : workers) w.join();
  }
  int listener_ = -1;
  uint16_t port_ = 0;
  std::thread thread_;
};

// ---- a CAMUS space of real processes ------------------------------------------------------

class Space {
 public:
  explicit Space(const std::string& dir) : dir_(dir) {
    std::ofstream(dir_ + "/sam.yaml") << "agents:\n  - {name: diag, type: diagnostic}\n";
    start_server(0);
    sam_ = std::make_unique<urs::test::Process>(
        std::vector<std::string>{URS_SAM_BIN, "--space", "bench", "--server", address(), "--config",
                                 dir_ + "/sam.yaml", "--log-level", "warn"},
        dir_ + "/sam.log");
  }
  void start_server(int port) {
    std::filesystem::remove(dir_ + "/port");
    server_ = std::make_unique<urs::test::Process>(
        std::vector<std::string>{URS_SERVER_BIN, "--space", "bench", "--listen",
                                 "127.0.0.1:" + std::to_string(port), "--data-dir", dir_ + "/data",
                                 "--port-file", dir_ + "/port", "--log-level", "warn"},
        dir_ + "/server.log");
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
  int port_ = 0;
  std::unique_ptr<urs::test::Process> server_;
  std::unique_ptr<urs::test::Process> sam_;
};

std::unique_ptr<urs::planet::Client> connect(uint16_t port, urs::planet::Role role = urs::planet::CLIENT) {
  urs::planet::ClientOptions options;
  options.port = port;
  options.role = role;
  options.peer_name = "bench";
  auto client = std::make_unique<urs::planet::Client>(options);
  client->start();
  if (!client->wait_connected(5s)) throw std::runtime_error("bench client cannot connect: " + client->last_error());
  return client;
}

void expect_ok(const urs::planet::CallResult& r, const char* what) {
  if (!r.ok()) throw std::runtime_error(std::string(what) + ": " + std::string(urs::planet::status_name(r.status)) + ": " + r.message);
}

long rss_kib(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/status");
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind("VmRSS:", 0) == 0) return std::stol(line.substr(6));
  }
  return -1;
}

std::string fmt_us(double us) {
  char b[32];
  std::snprintf(b, sizeof(b), us >= 1000 ? "%.2f ms" : "%.1f us", us >= 1000 ? us / 1000 : us);
  return b;
}

}  // namespace

int main(int argc, char** argv) {
  bool quick = false;
  std::string json_path;
  std::string markdown_path;
  for (int i = 1; i < argc; ++i) {
    std::string a = argv[i];
    if (a == "--quick") quick = true;
    else if (a == "--json" && i + 1 < argc) json_path = argv[++i];
    else if (a == "--markdown" && i + 1 < argc) markdown_path = argv[++i];
    else {
      std::cerr << "usage: urs-bench [--quick] [--json FILE] [--markdown FILE]\n";
      return 2;
    }
  }
  signal(SIGPIPE, SIG_IGN);
  urs::util::init_logging("urs-bench", "warn");  // stderr; stdout carries only the report
  const int warmup = quick ? 20 : 500;
  const int iterations = quick ? 50 : 2000;
  const int big_iterations = quick ? 5 : 100;
  const int repetitions = quick ? 1 : 5;

  std::string dir = urs::test::make_temp_dir("bench");
  std::vector<Row> rows;
  std::vector<std::pair<std::string, std::string>> extras;  // name, value
  try {
    RawEcho echo;
    Space space(dir);
    auto client = connect(space.port());
    if (!urs::test::wait_until([&] {
          URS::Diagnostic_echo_Request probe;
          return client->call("diag", "echo", probe.SerializeAsString(), 500ms).ok();
        }, 10s)) {
      throw std::runtime_error("diag never became callable: " + space.sam().log());
    }

    // 64-byte calls.
    int fd = echo.connect_client();
    std::string small(64, 'x');
    rows.push_back({"raw TCP echo", "64 B", urs::bench::measure([&] { RawEcho::round_trip(fd, small); }, warmup, iterations, repetitions), "", 0});
    URS::Diagnostic_echo_Request echo_req;
    echo_req.set_text(std::string(64, 'x'));
    const std::string echo_payload = echo_req.SerializeAsString();
    rows.push_back({"Planet call client→server→SAM→SA", "64 B",
                    urs::bench::measure([&] { expect_ok(client->call("diag", "echo", echo_payload, 5s), "echo"); },
                                        warmup, iterations, repetitions),
                    "raw TCP echo|64 B", 2.5});

    // 921,600-byte replies.
    std::string big(921600, 'x');
    rows.push_back({"raw TCP echo", "921,600 B", urs::bench::measure([&] { RawEcho::round_trip(fd, big); }, 3, big_iterations, repetitions), "", 0});
    URS::Diagnostic_blob_Request blob_req;
    blob_req.set_size(921600);
    const std::string blob_payload = blob_req.SerializeAsString();
    rows.push_back({"Planet call client→server→SAM→SA", "921,600 B",
                    urs::bench::measure([&] { expect_ok(client->call("diag", "blob", blob_payload, 10s), "blob"); },
                                        3, big_iterations, repetitions),
                    "raw TCP echo|921,600 B", 0});
    close(fd);

    // Throughput: calls per second with 1 and 4 concurrent clients.
    for (int clients : {1, 4}) {
      std::vector<std::unique_ptr<urs::planet::Client>> pool;
      for (int c = 0; c < clients; ++c) pool.push_back(connect(space.port()));
      const int per_client = quick ? 200 : 5000;
      auto t0 = std::chrono::steady_clock::now();
      std::vector<std::thread> threads;
      for (auto& c : pool) {
        threads.emplace_back([&, cl = c.get()] {
          for (int i = 0; i < per_client; ++i) expect_ok(cl->call("diag", "echo", echo_payload, 5s), "echo");
        });
      }
      for (auto& t : threads) t.join();
      double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      char value[64];
      std::snprintf(value, sizeof(value), "%.0f calls/s", clients * per_client / seconds);
      extras.push_back({"Planet throughput, " + std::to_string(clients) + " client(s), 64 B", value});
    }

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
      if (!urs::test::wait_until([&] { return done.load() == 1000; }, 30s)) throw std::runtime_error("registrations did not complete");
      extras.push_back({"RSS urs-camus-server, 1,000 services", std::to_string(rss_kib(space.server().pid())) + " KiB"});
    }

    // Recovery: kill -9 the server, restart it on the same port, until the SAM's agent answers.
    std::vector<double> recoveries;
    for (int r = 0; r < (quick ? 1 : 5); ++r) {
      int port = space.port();
      space.server().kill9();
      auto t0 = std::chrono::steady_clock::now();
      space.start_server(port);
      auto probe = connect(space.port());
      URS::Diagnostic_echo_Request ping;
      if (!urs::test::wait_until([&] { return probe->call("diag", "echo", ping.SerializeAsString(), 200ms).ok(); }, 10s)) {
        throw std::runtime_error("diag not callable after a server restart");
      }
      recoveries.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
    }
    char value[64];
    std::snprintf(value, sizeof(value), "median %.0f ms, max %.0f ms (goal <= 1000 ms)",
                  urs::bench::percentile(recoveries, 0.5), urs::bench::percentile(recoveries, 1.0));
    extras.push_back({"recovery after server kill -9 until SA callable", value});
  } catch (const std::exception& e) {
    std::cerr << "urs-bench: " << e.what() << "\n";
    std::filesystem::remove_all(dir);
    return 1;
  }
  std::filesystem::remove_all(dir);

  // Report.
  std::ostringstream md;
  md << "| path | payload | median | p99 | spread of medians | vs baseline | goal |\n|---|---|---|---|---|---|---|\n";
  std::ostringstream json;
  json << "{\"quick\":" << (quick ? "true" : "false") << ",\"rows\":[";
  for (size_t i = 0; i < rows.size(); ++i) {
    const auto& row = rows[i];
    std::string ratio = "baseline";
    std::string goal = "";
    for (const auto& base : rows) {
      if (base.path + "|" + base.payload == row.baseline) {
        char b[64];
        double x = row.summary.median_us / base.summary.median_us;
        std::snprintf(b, sizeof(b), "%.2fx %s", x, base.path.c_str());
        ratio = b;
        if (row.goal_ratio > 0) {
          std::snprintf(b, sizeof(b), "<= %.1fx: %s", row.goal_ratio, x <= row.goal_ratio ? "met" : "missed");
          goal = b;
        }
      }
    }
    md << "| " << row.path << " | " << row.payload << " | " << fmt_us(row.summary.median_us) << " | "
       << fmt_us(row.summary.p99_us) << " | " << fmt_us(row.summary.min_median_us) << " – "
       << fmt_us(row.summary.max_median_us) << " | " << ratio << " | " << goal << " |\n";
    json << (i ? "," : "") << "{\"path\":\"" << row.path << "\",\"payload\":\"" << row.payload
         << "\",\"median_us\":" << row.summary.median_us << ",\"p99_us\":" << row.summary.p99_us
         << ",\"min_median_us\":" << row.summary.min_median_us << ",\"max_median_us\":" << row.summary.max_median_us
         << ",\"samples\":" << row.summary.samples << "}";
  }
  json << "],\"other\":{";
  md << "\n| measurement | value |\n|---|---|\n";
  for (size_t i = 0; i < extras.size(); ++i) {
    md << "| " << extras[i].first << " | " << extras[i].second << " |\n";
    json << (i ? "," : "") << "\"" << extras[i].first << "\":\"" << extras[i].second << "\"";
  }
  json << "}}\n";
  std::cout << md.str();
  if (!json_path.empty()) std::ofstream(json_path) << json.str();
  if (!markdown_path.empty()) std::ofstream(markdown_path) << md.str();
  return 0;
}
