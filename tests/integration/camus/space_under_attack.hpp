#pragma once
// A space under attack, for the tests of its trust boundary (trust_test.cpp, fair_share_test.cpp):
// a real urs-camus-server with named credentials, a real urs-sam hosting the diagnostic agent and a
// legitimate client calling and receiving events throughout; helpers to attack it over raw
// connections and to record what it cost.

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <signal.h>

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "Diagnostic.pb.h"
#include "camus.pb.h"
#include "process.hpp"
#include "raw_peer.hpp"
#include "urs/planet/client.hpp"

namespace urs::camus_server::test {

using namespace std::chrono_literals;
using urs::test::Process;
using urs::test::RawPeer;
using Clock = std::chrono::steady_clock;

// The server may hold this much resident memory at any point of an attack.
inline constexpr long kMaxRssKib = 512 * 1024;

// One piece of a chunked message, as a frame.
inline planet::Frame chunk_piece(uint64_t message_id, uint64_t total, uint64_t offset, size_t size) {
  planet::Frame frame;
  frame.mutable_chunk()->set_message_id(message_id);
  frame.mutable_chunk()->set_total_bytes(total);
  frame.mutable_chunk()->set_offset(offset);
  frame.mutable_chunk()->set_data(std::string(size, 'm'));
  frame.mutable_chunk()->set_last(offset + size == total);
  return frame;
}

inline long rss_kib(pid_t pid) { return urs::test::resident_kib(pid); }

inline double median(std::vector<double> values) {
  if (values.empty()) return -1;
  std::sort(values.begin(), values.end());
  return values[values.size() / 2];
}

// A legitimate client during an attack: calls diag.echo and publishes/receives a tick event,
// over and over with a 5 ms pause, recording latencies and anything that failed.
class LegitimateClient {
  template <class F>
  auto locked(F f) const {
    std::lock_guard<std::mutex> lock(mutex_);
    return f();
  }

 public:
  LegitimateClient(uint16_t port, const std::string& token) {
    planet::ClientOptions options;
    options.port = port;
    options.token = token;
    options.peer_name = "legit";
    client_ = std::make_unique<planet::Client>(options);
    client_->start();
    if (!client_->wait_connected(10s)) throw std::runtime_error("legit client: " + client_->last_error());
    subscription_ = client_->subscribe("legit/tick", [this](const planet::Event& event) {
      const auto sent = Clock::time_point(Clock::duration(std::stoll(event.payload())));
      std::lock_guard<std::mutex> lock(mutex_);
      event_ms_.push_back(std::chrono::duration<double, std::milli>(Clock::now() - sent).count());
      changed_.notify_all();
    });
    // The subscription is in place once an event published after it arrives.
    client_->publish("legit/tick", std::to_string(Clock::now().time_since_epoch().count()), "text/plain");
    std::unique_lock<std::mutex> lock(mutex_);
    if (!changed_.wait_for(lock, 10s, [this] { return !event_ms_.empty(); })) {
      throw std::runtime_error("legit client: its first event did not come back");
    }
    event_ms_.clear();
  }

  void start() {
    thread_ = std::thread([this] {
      while (!stop_) {
        URS::Diagnostic_echo_Request echo;
        echo.set_text("still here");
        const auto start = Clock::now();
        auto result = client_->call("diag", "echo", echo.SerializeAsString(), 20s);
        const double ms = std::chrono::duration<double, std::milli>(Clock::now() - start).count();
        URS::Diagnostic_echo_Reply reply;
        {
          std::lock_guard<std::mutex> lock(mutex_);
          if (result.ok() && reply.ParseFromString(result.payload) && reply.result() == "still here") {
            call_ms_.push_back(ms);
          } else {
            failures_.push_back(std::string(planet::status_name(result.status)) + " " + result.message);
          }
        }
        if (client_->publish("legit/tick", std::to_string(Clock::now().time_since_epoch().count()), "text/plain")
                .ok()) {
          ++ticks_;
        }
        std::unique_lock<std::mutex> lock(mutex_);
        changed_.wait_for(lock, 5ms, [this] { return stop_.load(); });
      }
    });
  }

  // Stops, then waits (bounded) for the ticks still on their way.
  void stop() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stop_ = true;
      changed_.notify_all();
    }
    if (thread_.joinable()) thread_.join();
    std::unique_lock<std::mutex> lock(mutex_);
    changed_.wait_for(lock, 30s, [this] { return event_ms_.size() >= ticks_; });
  }

  size_t calls() const {
    return locked([&] { return call_ms_.size(); });
  }
  std::vector<std::string> failures() const {
    return locked([&] { return failures_; });
  }
  size_t ticks() const { return ticks_; }
  size_t events() const {
    return locked([&] { return event_ms_.size(); });
  }
  double call_median_ms() const {
    return locked([&] { return median(call_ms_); });
  }
  double event_median_ms() const {
    return locked([&] { return median(event_ms_); });
  }
  planet::Client& client() { return *client_; }

 private:
  std::unique_ptr<planet::Client> client_;
  uint64_t subscription_ = 0;
  mutable std::mutex mutex_;
  std::condition_variable changed_;
  std::vector<double> call_ms_;
  std::vector<double> event_ms_;
  std::vector<std::string> failures_;
  std::atomic<size_t> ticks_{0};
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

class TrustTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = urs::test::make_temp_dir("trust");
    for (const char* name : {"ops", "sam", "viewer", "intruder", "newbie", "mallory"}) {
      write(dir_ + "/" + name + ".token", std::string(name) + "-" + std::to_string(::getpid()) + "-secret-token\n");
    }
    // mallory: the least-privileged attacker (role client).
    write_credentials(
        {{"ops", "operator"}, {"sam-robot1", "sam"}, {"viewer", "client"}, {"intruder", "sam"}, {"mallory", "client"}});
    write(dir_ + "/sam.yaml",
          "agents:\n"
          "  - name: diag\n"
          "    type: diagnostic\n"
          "    deadline_ms: 5000\n");
  }

  void TearDown() override {
    if (HasFailure()) {
      std::cerr << "---- server log (tail)\n"
                << tail(server_ ? server_->log() : "") << "---- sam log (tail)\n"
                << tail(sam_ ? sam_->log() : "");
    }
    legit_.reset();
    sam_.reset();
    server_.reset();
    std::filesystem::remove_all(dir_);
  }

  static std::string tail(const std::string& text) {
    return text.size() > 6000 ? text.substr(text.size() - 6000) : text;
  }

  // Credentials by name and role; "sam-robot1" uses sam.token, the others their own name's.
  void write_credentials(const std::vector<std::pair<std::string, std::string>>& entries) {
    std::string yaml = "credentials:\n";
    for (const auto& [name, role] : entries) {
      const std::string file = name == "sam-robot1" ? "sam.token" : name + ".token";
      yaml += "  - name: " + name + "\n    role: " + role + "\n    token_file: " + file + "\n";
    }
    write(dir_ + "/credentials.yaml", yaml);
  }

  void start_server(const std::vector<std::string>& extra = {}) {
    std::vector<std::string> argv = server_prefix_;
    std::vector<std::string> own{URS_CAMUS_SERVER_BIN,
                                 "--space",
                                 "kr",
                                 "--listen",
                                 "127.0.0.1:0",
                                 "--port-file",
                                 dir_ + "/port",
                                 "--data-dir",
                                 dir_ + "/data",
                                 "--credentials",
                                 dir_ + "/credentials.yaml",
                                 "--log-level",
                                 "debug"};
    argv.insert(argv.end(), own.begin(), own.end());
    argv.insert(argv.end(), extra.begin(), extra.end());
    server_ = std::make_unique<Process>(argv, dir_ + "/server.log");
    ASSERT_TRUE(urs::test::wait_until([&] { return std::filesystem::exists(dir_ + "/port"); }, 20s)) << server_->log();
    port_ = static_cast<uint16_t>(std::stoi(urs::test::read_text(dir_ + "/port")));
  }

  void start_space(const std::vector<std::string>& extra = {}) {
    start_server(extra);
    if (HasFatalFailure()) return;
    sam_ = std::make_unique<Process>(
        std::vector<std::string>{URS_SAM_BIN, "--space", "kr", "--server", address(), "--config", dir_ + "/sam.yaml",
                                 "--token-file", dir_ + "/sam.token", "--log-level", "debug"},
        dir_ + "/sam.log");
    ASSERT_TRUE(urs::test::wait_until(
        [&] {
          auto r = urs("viewer", {"--timeout-ms", "1000", "ls", "diag"});
          return r.exit_code == 0 && r.out.find("diag ") != std::string::npos;
        },
        30s))
        << sam_->log();
  }

  std::string address() const { return "127.0.0.1:" + std::to_string(port_); }
  std::string token(const std::string& name) const { return urs::test::read_text(dir_ + "/" + name + ".token"); }
  std::string token_value(const std::string& name) const {
    std::string t = token(name);
    t.erase(t.find_last_not_of(" \n") + 1);
    return t;
  }

  urs::test::CommandResult urs(const std::string& who, std::vector<std::string> args) {
    std::vector<std::string> argv{URS_CLI_BIN, "--server", address(), "--token-file", dir_ + "/" + who + ".token"};
    argv.insert(argv.end(), args.begin(), args.end());
    return urs::test::run_command(argv, 30s);
  }

  std::unique_ptr<planet::Client> client(const std::string& who, planet::Role role = planet::CLIENT,
                                         const std::string& peer = "") {
    planet::ClientOptions options;
    options.port = port_;
    options.token = token_value(who);
    options.peer_name = peer.empty() ? who : peer;
    options.role = role;
    auto c = std::make_unique<planet::Client>(options);
    return c;
  }

  // A raw connection that completed its handshake as `who`; returns its Welcome.
  planet::Welcome raw_hello(RawPeer& raw, const std::string& who, planet::Role role = planet::CLIENT,
                            const std::string& secret = "", const std::string& peer = "raw") {
    raw.send_hello(1, token_value(who), peer, secret, role);
    auto frame = raw.read_non_ping(10s);
    if (!frame || !frame->has_welcome()) {
      ADD_FAILURE() << "no Welcome for " << who << ": " << (frame ? frame->ShortDebugString() : "nothing");
      return {};
    }
    return frame->welcome();
  }

  // The next frame of `kind` on `raw`, answering Pings meanwhile.
  static std::optional<planet::Frame> next(RawPeer& raw, planet::Frame::BodyCase kind,
                                           std::chrono::milliseconds timeout = 20s) {
    const auto deadline = Clock::now() + timeout;
    while (Clock::now() < deadline) {
      auto frame = raw.read_frame(std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()));
      if (!frame) return std::nullopt;
      if (frame->has_ping()) {
        planet::Frame pong;
        pong.mutable_pong()->set_nonce(frame->ping().nonce());
        raw.send_frame(pong);
        continue;
      }
      if (frame->body_case() == kind) return frame;
    }
    return std::nullopt;
  }

  static planet::Frame request(uint64_t id, const std::string& service, const std::string& op,
                               const std::string& payload = "", uint64_t deadline_ms = 0) {
    planet::Frame frame;
    auto* r = frame.mutable_request();
    r->set_call_id(id);
    r->set_service(service);
    r->set_operation(op);
    r->set_payload(payload);
    r->set_deadline_ms(deadline_ms);
    return frame;
  }

  // Sends a Request on `raw` and returns its Reply (nullopt if none came).
  static std::optional<planet::Reply> ask(RawPeer& raw, uint64_t id, const std::string& service, const std::string& op,
                                          const google::protobuf::Message& payload) {
    raw.send_frame(request(id, service, op, payload.SerializeAsString()));
    auto reply = next(raw, planet::Frame::kReply);
    if (!reply) return std::nullopt;
    return reply->reply();
  }

  static camus::RegisterRequest registration(const std::string& name, const std::string& interface) {
    camus::RegisterRequest r;
    r.mutable_service()->set_name(name);
    r.mutable_service()->set_interface(interface);
    return r;
  }

  // Starts the space and a legitimate client that calls diag.echo and publishes ticks until
  // end_attack(); notes the server's memory first.
  void begin_attack(const std::vector<std::string>& extra = {}) {
    start_space(extra);
    if (HasFatalFailure()) return;
    legit_ = std::make_unique<LegitimateClient>(port_, token_value("viewer"));
    rss_before_ = rss_kib(server_->pid());
    rss_peak_ = rss_before_;
    legit_->start();
  }

  void sample_memory() { rss_peak_ = std::max(rss_peak_, rss_kib(server_->pid())); }

  // Stops the legitimate client; asserts it was served throughout (every call answered, every
  // tick delivered) and the server stayed under kMaxRssKib; prints and records the figures.
  void end_attack(const std::string& attack, std::map<std::string, double> values = {}) {
    legit_->stop();
    sample_memory();
    const long after = rss_kib(server_->pid());
    EXPECT_TRUE(legit_->failures().empty()) << legit_->failures().front();
    EXPECT_GT(legit_->calls(), 0u);
    EXPECT_EQ(legit_->events(), legit_->ticks()) << "a legitimate event was lost";
    EXPECT_LT(rss_peak_, kMaxRssKib);
    values["rss_before_kib"] = rss_before_;
    values["rss_peak_kib"] = rss_peak_;
    values["rss_after_kib"] = after;
    values["legit_call_median_ms"] = legit_->call_median_ms();
    values["legit_event_median_ms"] = legit_->event_median_ms();
    values["legit_calls"] = static_cast<double>(legit_->calls());
    figure(attack, values);
  }

  void figure(const std::string& attack, const std::map<std::string, double>& values) {
    std::string line = "FIGURE " + attack;
    for (const auto& [key, value] : values) {
      line += " " + key + "=" + std::to_string(value);
      RecordProperty(attack + "_" + key, std::to_string(value));
    }
    std::cout << line << std::endl;
  }

  static void write(const std::string& path, const std::string& text) { std::ofstream(path) << text; }

  std::string dir_;
  std::vector<std::string> server_prefix_;  // run the server under this command (e.g. prlimit ...)
  uint16_t port_ = 0;
  std::unique_ptr<Process> server_;
  std::unique_ptr<Process> sam_;
  std::unique_ptr<LegitimateClient> legit_;
  long rss_before_ = 0;
  long rss_peak_ = 0;
};

}  // namespace urs::camus_server::test
