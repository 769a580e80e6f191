// The trust boundary of a space, attacked on loopback: a real urs-camus-server with named
// credentials, a real urs-sam hosting the diagnostic agent, legitimate clients calling and
// receiving events throughout, and attackers doing what an independent implementer did to the
// server. Each test asserts that the attacker gets the documented refusal, that the legitimate
// client keeps being served, that nothing acknowledged is lost and that the server's resident
// memory (VmRSS of the real process) stays under a stated bound. The figures (memory before and
// after, the legitimate client's median call and event latency during the attack) are printed
// and recorded as test properties; they are measured, not asserted.

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <signal.h>

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <filesystem>
#include <fstream>
#include <future>
#include <map>
#include <mutex>
#include <regex>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "Diagnostic.pb.h"
#include "camus.pb.h"
#include "process.hpp"
#include "raw_peer.hpp"
#include "urs/planet/client.hpp"

namespace urs::camus_server::test {
namespace {

using namespace std::chrono_literals;
using ::testing::HasSubstr;
using urs::test::Process;
using urs::test::RawPeer;
using Clock = std::chrono::steady_clock;

// The server may hold this much resident memory at any point of an attack.
constexpr long kMaxRssKib = 512 * 1024;

long rss_kib(pid_t pid) { return urs::test::resident_kib(pid); }

double median(std::vector<double> values) {
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

  size_t calls() const { return locked([&] { return call_ms_.size(); }); }
  std::vector<std::string> failures() const { return locked([&] { return failures_; }); }
  size_t ticks() const { return ticks_; }
  size_t events() const { return locked([&] { return event_ms_.size(); }); }
  double call_median_ms() const { return locked([&] { return median(call_ms_); }); }
  double event_median_ms() const { return locked([&] { return median(event_ms_); }); }
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
    for (const char* name : {"ops", "sam", "viewer", "intruder", "newbie"}) {
      write(dir_ + "/" + name + ".token", std::string(name) + "-" + std::to_string(::getpid()) + "-secret-token\n");
    }
    write_credentials({{"ops", "operator"}, {"sam-robot1", "sam"}, {"viewer", "client"}, {"intruder", "sam"}});
    write(dir_ + "/sam.yaml",
          "agents:\n"
          "  - name: diag\n"
          "    type: diagnostic\n"
          "    deadline_ms: 5000\n");
  }

  void TearDown() override {
    if (HasFailure()) {
      std::cerr << "---- server log (tail)\n" << tail(server_ ? server_->log() : "") << "---- sam log (tail)\n"
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
    std::vector<std::string> argv{URS_CAMUS_SERVER_BIN, "--space", "kr", "--listen", "127.0.0.1:0", "--port-file",
                                  dir_ + "/port", "--data-dir", dir_ + "/data", "--credentials",
                                  dir_ + "/credentials.yaml", "--log-level", "debug"};
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
  uint16_t port_ = 0;
  std::unique_ptr<Process> server_;
  std::unique_ptr<Process> sam_;
  std::unique_ptr<LegitimateClient> legit_;
  long rss_before_ = 0;
  long rss_peak_ = 0;
};

// 50,000 events on a 32-level topic while 2,000 subscriptions that never match are held: every
// publish is acknowledged (OK or RESOURCE_EXHAUSTED naming the limit), every event acknowledged
// OK reaches the subscriber of its topic, and a legitimate client's calls and events keep flowing.
TEST_F(TrustTest, BusFloodWithThousandsOfNonMatchingSubscriptions) {
  begin_attack();
  ASSERT_FALSE(HasFatalFailure());
  Process flood({URS_BUS_FLOOD_BIN, "--server", address(), "--token-file", dir_ + "/intruder.token", "--subscriptions",
                 "2000", "--sessions", "2", "--events", "50000", "--levels", "32", "--timeout-s", "240"},
                dir_ + "/flood.log");
  int code = -1;
  const auto deadline = Clock::now() + 270s;
  while (code == -1 && Clock::now() < deadline) {
    sample_memory();
    code = flood.wait(200ms);
  }
  const std::string out = flood.log();
  ASSERT_EQ(code, 0) << out;
  std::smatch m;
  auto number = [&](const std::string& key) {
    EXPECT_TRUE(std::regex_search(out, m, std::regex("\"" + key + "\":([-0-9.e+]+)"))) << key << " in " << out;
    return std::stod(m[1].str());
  };
  EXPECT_EQ(number("subscribed"), 2000);
  EXPECT_EQ(number("ok") + number("exhausted"), 50000) << out;
  EXPECT_EQ(number("other"), 0) << out;
  EXPECT_EQ(number("missing"), 0) << "events acknowledged OK that never reached the subscriber: " << out;
  EXPECT_EQ(number("unacked_delivered"), 0) << out;
  if (number("exhausted") > 0) {
    EXPECT_THAT(out, HasSubstr("(event_queue"));
  }
  end_attack("bus_flood", {{"ok_per_s", number("ok_per_s")},
                           {"ack_s", number("ack_s")},
                           {"deliver_s", number("deliver_s")},
                           {"ok", number("ok")},
                           {"exhausted", number("exhausted")}});

  // The topic of the original attack had 200 levels: refused before it is queued.
  RawPeer raw(port_);
  raw_hello(raw, "intruder");
  std::string deep = "a";
  for (int i = 1; i < 200; ++i) deep += "/a";
  planet::Frame publish;
  publish.mutable_publish()->set_publish_id(1);
  publish.mutable_publish()->set_topic(deep);
  raw.send_frame(publish);
  auto ack = next(raw, planet::Frame::kPublishAck);
  ASSERT_TRUE(ack);
  EXPECT_EQ(ack->publish_ack().status(), planet::BAD_ARGUMENTS);
  EXPECT_THAT(ack->publish_ack().message(), HasSubstr("it has 200 levels; the limit is 32 (max_topic_levels)"));
}

// 3,000 subscriptions with a 60 KB pattern or a 30,000-level pattern (they cost 1.4 GiB before),
// then one valid subscription too many.
TEST_F(TrustTest, HugePatternsAreRefusedAndSubscriptionsAreBounded) {
  begin_attack();
  ASSERT_FALSE(HasFatalFailure());
  RawPeer raw(port_);
  raw_hello(raw, "intruder");
  const std::string wide(60 * 1024, 'w');
  std::string deep = "d";
  for (int i = 1; i < 30000; ++i) deep += "/d";
  std::thread sender([&] {
    for (uint64_t id = 1; id <= 3000; ++id) {
      planet::Frame frame;
      frame.mutable_subscribe()->set_subscription_id(id);
      frame.mutable_subscribe()->set_pattern(id % 2 == 0 ? wide : deep);
      raw.send_frame(frame);
    }
  });
  size_t refused = 0;
  std::string message;
  for (size_t i = 0; i < 3000; ++i) {
    auto ack = next(raw, planet::Frame::kSubscribeAck, 60s);
    ASSERT_TRUE(ack) << "after " << i << " acks";
    if (ack->subscribe_ack().status() == planet::BAD_ARGUMENTS) ++refused;
    if (message.empty()) message = ack->subscribe_ack().message();
    if (i % 100 == 0) sample_memory();
  }
  sender.join();
  EXPECT_EQ(refused, 3000u);
  EXPECT_THAT(message, HasSubstr("bytes long; the limit is 512 (max_topic_bytes)"));
  EXPECT_LT(message.size(), 300u) << "the refusal quotes the pattern, not all of it";

  // Valid ones: 1,000 per session, then RESOURCE_EXHAUSTED naming the limit.
  for (uint64_t id = 1; id <= 1001; ++id) {
    planet::Frame frame;
    frame.mutable_subscribe()->set_subscription_id(10000 + id);
    frame.mutable_subscribe()->set_pattern("kr/robot" + std::to_string(id) + "/#");
    raw.send_frame(frame);
  }
  size_t accepted = 0;
  std::vector<planet::SubscribeAck> refusals;
  for (size_t i = 0; i < 1001; ++i) {
    auto ack = next(raw, planet::Frame::kSubscribeAck, 60s);
    ASSERT_TRUE(ack);
    if (ack->subscribe_ack().status() == planet::OK) {
      ++accepted;
    } else {
      refusals.push_back(ack->subscribe_ack());
    }
  }
  EXPECT_EQ(accepted, 1000u);
  ASSERT_EQ(refusals.size(), 1u);
  EXPECT_EQ(refusals[0].status(), planet::RESOURCE_EXHAUSTED);
  // The subscriptions a session may hold; or, if the bus was behind when the 1,001st arrived, the
  // operations a session may have queued (both 1,000).
  EXPECT_THAT(refusals[0].message(),
              ::testing::AnyOf(HasSubstr("this session already has 1000 subscriptions (max_subscriptions_per_session 1000)"),
                               HasSubstr("(event_queue_per_session 1000)")));
  EXPECT_LT(rss_kib(server_->pid()) - rss_before_, 64 * 1024)
      << "3,000 refused and 1,000 held subscriptions cost over 64 MiB";
  end_attack("huge_patterns");
}

// Everything the SAM and the server print is tried as a session secret by a stranger holding a
// credential of its own: it cannot take the SAM's session, service, ownership or publish ids.
TEST_F(TrustTest, WhatTheSamLogsDoesNotLetAStrangerTakeItsSessionOver) {
  begin_attack();
  ASSERT_FALSE(HasFatalFailure());
  LegitimateClient& legit = *legit_;
  std::set<std::string> candidates;
  const std::regex secretish("[0-9A-Za-z+/=_-]{16,}");
  for (const std::string& log : {sam_->log(), server_->log()}) {
    for (std::sregex_iterator it(log.begin(), log.end(), secretish), end; it != end; ++it) {
      candidates.insert(it->str());
    }
  }
  ASSERT_FALSE(candidates.empty());
  // Nothing shaped like a session secret (64 hex digits), nor like the old client-chosen session
  // id (32 hex digits), is in either log.
  const std::regex hex_secret("[0-9a-f]{32,}");
  EXPECT_FALSE(std::regex_search(sam_->log(), hex_secret)) << sam_->log();
  EXPECT_FALSE(std::regex_search(server_->log(), hex_secret));
  std::set<std::string> tried;
  for (const auto& candidate : candidates) {
    if (tried.size() == 40) break;
    tried.insert(candidate);
    RawPeer raw(port_);
    const planet::Welcome welcome = raw_hello(raw, "intruder", planet::SAM, candidate, "sam@robot1");
    EXPECT_EQ(welcome.identity(), "intruder");
    EXPECT_NE(welcome.session_secret(), candidate) << "a logged string resumed a session";
  }
  // The stranger tries to take the service over, then to remove it.
  RawPeer raw(port_);
  raw_hello(raw, "intruder", planet::SAM, *candidates.begin(), "sam@robot1");
  auto reply = ask(raw, 1, "camus.registry", "Register", registration("diag", "URS.Diagnostic"));
  ASSERT_TRUE(reply);
  EXPECT_EQ(reply->status(), planet::ALREADY_EXISTS);
  EXPECT_EQ(reply->message(), "service diag is provided by sam-robot1");
  camus::UnregisterRequest remove;
  remove.set_name("diag");
  reply = ask(raw, 2, "camus.registry", "Unregister", remove);
  ASSERT_TRUE(reply);
  EXPECT_EQ(reply->status(), planet::PERMISSION_DENIED);
  // ... and to poison the publish ids the SAM will use.
  for (uint64_t id = 1; id <= 200; ++id) {
    planet::Frame publish;
    publish.mutable_publish()->set_publish_id(id);
    publish.mutable_publish()->set_topic("kr/poison");
    raw.send_frame(publish);
  }
  for (int i = 0; i < 200; ++i) ASSERT_TRUE(next(raw, planet::Frame::kPublishAck));

  // The SAM still answers its service, owns it, and its events are delivered with its identity.
  std::mutex mutex;
  std::condition_variable cv;
  std::vector<planet::Event> notified;
  legit.client().subscribe("kr/notify/#", [&](const planet::Event& event) {
    std::lock_guard<std::mutex> lock(mutex);
    notified.push_back(event);
    cv.notify_all();
  });
  URS::Diagnostic_echo_Request echo;
  echo.set_text("who answers?");
  auto answered = legit.client().call("diag", "echo", echo.SerializeAsString(), 10s);
  ASSERT_TRUE(answered.ok()) << answered.message;
  URS::Diagnostic_echo_Reply echoed;
  ASSERT_TRUE(echoed.ParseFromString(answered.payload));
  EXPECT_EQ(echoed.result(), "who answers?");
  // The subscription is in place once the call above returned? Not necessarily: notify until seen.
  ASSERT_TRUE(urs::test::wait_until(
      [&] {
        URS::Diagnostic_notify_Request notify;
        notify.set_topic("kr/notify/real");
        notify.set_text("from the real SAM");
        legit.client().oneway("diag", "notify", notify.SerializeAsString());
        std::unique_lock<std::mutex> lock(mutex);
        return cv.wait_for(lock, 500ms, [&] { return !notified.empty(); });
      },
      20s));
  {
    std::lock_guard<std::mutex> lock(mutex);
    EXPECT_EQ(notified[0].source(), "sam-robot1");
    URS::Diagnostic_notify_Request payload;
    ASSERT_TRUE(payload.ParseFromString(notified[0].payload()));
    EXPECT_EQ(payload.text(), "from the real SAM");
    EXPECT_EQ(notified[0].content_type(), "URS.Diagnostic_notify_Request");
  }
  auto listed = urs("viewer", {"ls", "diag"});
  ASSERT_EQ(listed.exit_code, 0) << listed.err;
  EXPECT_THAT(listed.out, HasSubstr("sam-robot1"));
  EXPECT_THAT(listed.out, ::testing::Not(HasSubstr("intruder")));
  end_attack("session_theft", {{"secrets_tried", static_cast<double>(tried.size())}});
}

// A peer naming itself camus-server, and even an operator, cannot publish what the server does.
TEST_F(TrustTest, NobodySpeaksAsTheServer) {
  begin_attack();
  ASSERT_FALSE(HasFatalFailure());
  auto watcher = client("viewer");
  std::mutex mutex;
  std::vector<planet::Event> seen;
  watcher->start();
  ASSERT_TRUE(watcher->wait_connected(10s));
  watcher->subscribe("registry/#", [&](const planet::Event& e) {
    std::lock_guard<std::mutex> lock(mutex);
    seen.push_back(e);
  });
  watcher->subscribe("context/#", [&](const planet::Event& e) {
    std::lock_guard<std::mutex> lock(mutex);
    seen.push_back(e);
  });

  RawPeer named(port_);
  named.send_hello(1, token_value("ops"), "camus-server");
  auto refused = named.read_frame();
  ASSERT_TRUE(refused && refused->has_refused());
  EXPECT_EQ(refused->refused().status(), planet::BAD_ARGUMENTS);
  EXPECT_EQ(refused->refused().reason(), "peer_name is not valid: 'camus-server' is the server's own name");

  RawPeer ops(port_);
  raw_hello(ops, "ops", planet::CLIENT, "", "camus-server-2");
  camus::ServiceInfo gone;
  gone.set_name("diag");
  gone.set_state("gone");
  gone.set_owner("camus-server");
  uint64_t id = 0;
  for (const char* topic : {"registry/diag", "context/robot1/pose", "task/square-path/r1"}) {
    planet::Frame publish;
    publish.mutable_publish()->set_publish_id(++id);
    publish.mutable_publish()->set_topic(topic);
    publish.mutable_publish()->set_payload(gone.SerializeAsString());
    publish.mutable_publish()->set_content_type("urs.camus.ServiceInfo");
    ops.send_frame(publish);
    auto ack = next(ops, planet::Frame::kPublishAck);
    ASSERT_TRUE(ack);
    EXPECT_EQ(ack->publish_ack().status(), planet::PERMISSION_DENIED) << topic;
    EXPECT_THAT(ack->publish_ack().message(), HasSubstr("are published by the server alone"));
  }
  // An operator may set context, but the entry's source is who it is, whatever it declares.
  camus::ContextSetRequest set;
  set.set_key("robot1/pose");
  set.mutable_value()->set_string_value("forged?");
  set.set_source("camus-server");
  auto reply = ask(ops, 10, "camus.context", "Set", set);
  ASSERT_TRUE(reply);
  ASSERT_EQ(reply->status(), planet::OK) << reply->message();
  camus::ContextEntry entry;
  ASSERT_TRUE(entry.ParseFromString(reply->payload()));
  EXPECT_EQ(entry.source(), "ops");
  EXPECT_EQ(entry.origin(), "camus-server");

  ASSERT_TRUE(urs::test::wait_until(
      [&] {
        std::lock_guard<std::mutex> lock(mutex);
        return !seen.empty();
      },
      10s));
  {
    std::lock_guard<std::mutex> lock(mutex);
    for (const auto& event : seen) {
      EXPECT_EQ(event.source(), "camus-server") << event.topic();  // only the server's own events
      EXPECT_NE(event.topic(), "registry/diag") << "a forged registry event got through";
    }
  }
  auto listed = urs("viewer", {"ls", "diag"});
  EXPECT_THAT(listed.out, HasSubstr("available"));
  end_attack("impersonate_server");
}

// A provider learns who calls from the server (Request.caller: the name and role the server
// authenticated); a client that names a caller itself, to pass for another, is refused.
TEST_F(TrustTest, TheServerAloneNamesTheCaller) {
  start_space();
  ASSERT_FALSE(HasFatalFailure());
  RawPeer provider(port_);
  raw_hello(provider, "sam", planet::SAM);
  auto reply = ask(provider, 1, "camus.registry", "Register", registration("probe.svc", "URS.Diagnostic"));
  ASSERT_TRUE(reply);
  ASSERT_EQ(reply->status(), planet::OK) << reply->message();

  RawPeer viewer(port_);
  raw_hello(viewer, "viewer");
  URS::Diagnostic_echo_Request echo;
  echo.set_text("who am I");
  planet::Frame forged = request(1, "probe.svc", "echo", echo.SerializeAsString());
  forged.mutable_request()->mutable_caller()->set_name("ops");
  forged.mutable_request()->mutable_caller()->set_role(planet::OPERATOR);
  viewer.send_frame(forged);
  auto refused = next(viewer, planet::Frame::kReply);
  ASSERT_TRUE(refused);
  EXPECT_EQ(refused->reply().status(), planet::PERMISSION_DENIED);
  EXPECT_EQ(refused->reply().message(),
            "Request.caller is set by the server alone: probe.svc.echo not called (a client may not name who calls)");

  // The honest call reaches the provider naming its real caller; the forged one never did.
  viewer.send_frame(request(2, "probe.svc", "echo", echo.SerializeAsString()));
  auto routed = next(provider, planet::Frame::kRequest);
  ASSERT_TRUE(routed);
  EXPECT_EQ(routed->request().caller().name(), "viewer");
  EXPECT_EQ(routed->request().caller().role(), planet::CLIENT);
  planet::Frame answer;
  answer.mutable_reply()->set_call_id(routed->request().call_id());
  answer.mutable_reply()->set_status(planet::OK);
  provider.send_frame(answer);
  auto answered = next(viewer, planet::Frame::kReply);
  ASSERT_TRUE(answered);
  EXPECT_EQ(answered->reply().call_id(), 2u);
  EXPECT_EQ(answered->reply().status(), planet::OK) << answered->reply().message();
}

// Each role may do what it is given and gets PERMISSION_DENIED with the reason beyond.
TEST_F(TrustTest, WrongRolesArePermissionDenied) {
  start_space();
  ASSERT_FALSE(HasFatalFailure());
  auto r = urs("viewer", {"context", "set", "robot1/battery", "0.5"});
  EXPECT_NE(r.exit_code, 0);
  EXPECT_THAT(r.err, HasSubstr("PERMISSION_DENIED"));
  EXPECT_THAT(r.err, HasSubstr("camus.context.Set needs role operator; credential 'viewer' has role client"));
  r = urs("viewer", {"task", "run", "--file", dir_ + "/sam.yaml"});
  EXPECT_THAT(r.err, HasSubstr("camus.tasks.Run needs role operator"));
  r = urs("ops", {"context", "set", "robot1/battery", "0.5"});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  r = urs("viewer", {"context", "get", "robot1/battery"});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("\"source\":\"ops\""));
  r = urs("viewer", {"whoami"});
  EXPECT_EQ(r.out, "viewer client kr\n");

  RawPeer as_sam(port_);
  as_sam.send_hello(1, token_value("viewer"), "pretend-sam", "", planet::SAM);
  auto refused = as_sam.read_frame();
  ASSERT_TRUE(refused && refused->has_refused());
  EXPECT_EQ(refused->refused().status(), planet::PERMISSION_DENIED);
  EXPECT_EQ(refused->refused().reason(), "credential 'viewer' has role client; Hello asks for sam (to register services)");

  RawPeer viewer(port_);
  raw_hello(viewer, "viewer");
  const auto svc = registration("viewer.svc", "URS.Diagnostic");
  auto reply = ask(viewer, 1, "camus.registry", "Register", svc);
  ASSERT_TRUE(reply);
  EXPECT_EQ(reply->status(), planet::PERMISSION_DENIED);
  EXPECT_EQ(reply->message(), "camus.registry.Register needs role sam; credential 'viewer' has role client");

  RawPeer sam(port_);
  raw_hello(sam, "sam", planet::SAM);
  camus::ContextDeleteRequest remove;
  remove.set_key("robot1/battery");
  reply = ask(sam, 1, "camus.context", "Delete", remove);
  ASSERT_TRUE(reply);
  EXPECT_EQ(reply->status(), planet::PERMISSION_DENIED);
  reply = ask(sam, 2, "camus.registry", "Register", svc);
  ASSERT_TRUE(reply);
  EXPECT_EQ(reply->status(), planet::OK) << reply->message();
}

// Pending calls are bounded per connection; duplicate call ids and deadlines over the maximum
// are refused; a legitimate client's calls go on.
TEST_F(TrustTest, CallFloodsAreBoundedAndMalformedCallsRefused) {
  begin_attack({"--max-pending-calls-per-session", "50"});
  ASSERT_FALSE(HasFatalFailure());
  // A provider (the intruder's own, with a sam credential) that never answers.
  auto sink = client("intruder", planet::SAM);
  std::mutex held_mutex;
  std::vector<planet::Responder> held;
  sink->set_request_handler([&](const planet::Request&, planet::Responder responder) {
    std::lock_guard<std::mutex> lock(held_mutex);
    held.push_back(std::move(responder));
  });
  sink->start();
  ASSERT_TRUE(sink->wait_connected(10s));
  std::promise<planet::CallResult> registered;
  sink->register_service(registration("sink", "urs.Sink"),
                         [&](planet::CallResult r) { registered.set_value(std::move(r)); });
  auto done = registered.get_future();
  ASSERT_EQ(done.wait_for(10s), std::future_status::ready);
  ASSERT_TRUE(done.get().ok());

  RawPeer raw(port_);
  raw_hello(raw, "viewer");
  for (uint64_t id = 1; id <= 60; ++id) raw.send_frame(request(id, "sink", "hold", "", 60000));
  raw.send_frame(request(1, "sink", "hold", "", 60000));  // a duplicate of a pending id
  raw.send_frame(request(100, "sink", "hold", "", (uint64_t{1} << 32) + 5));
  std::map<uint64_t, planet::Reply> replies;
  std::vector<planet::Reply> duplicates;
  for (int i = 0; i < 12; ++i) {
    auto reply = next(raw, planet::Frame::kReply);
    ASSERT_TRUE(reply) << "after " << i << " replies";
    if (replies.count(reply->reply().call_id())) duplicates.push_back(reply->reply());
    replies[reply->reply().call_id()] = reply->reply();
  }
  for (uint64_t id = 51; id <= 60; ++id) {
    ASSERT_TRUE(replies.count(id)) << id;
    EXPECT_EQ(replies[id].status(), planet::RESOURCE_EXHAUSTED);
    EXPECT_EQ(replies[id].message(), "this connection already has 50 calls pending (max_pending_calls_per_session 50)");
  }
  ASSERT_TRUE(replies.count(1));
  EXPECT_EQ(replies[1].status(), planet::BAD_ARGUMENTS);
  EXPECT_THAT(replies[1].message(), HasSubstr("call_id 1 is already pending on this connection"));
  ASSERT_TRUE(replies.count(100));
  EXPECT_EQ(replies[100].message(), "deadline_ms 4294967301 exceeds the server's limit of 86400000 ms (max_deadline_ms)");
  // The 50 admitted calls reach the provider (the refusals may be answered before all of them
  // have arrived there); the refused ones never do.
  EXPECT_TRUE(urs::test::wait_until(
      [&] {
        std::lock_guard<std::mutex> lock(held_mutex);
        return held.size() >= 50u;
      },
      10s));
  {
    std::lock_guard<std::mutex> lock(held_mutex);
    EXPECT_EQ(held.size(), 50u);
  }
  end_attack("call_flood");
  sink->stop();
}

// SIGHUP re-reads the credentials file: a removed credential's sessions are closed and refused, a
// new one is admitted, the others go on; a broken file leaves the previous credentials in force.
TEST_F(TrustTest, SighupReloadsTheCredentials) {
  start_space();
  ASSERT_FALSE(HasFatalFailure());
  auto ops = client("ops");
  ops->start();
  ASSERT_TRUE(ops->wait_connected(10s));
  auto viewer = client("viewer");
  viewer->start();
  ASSERT_TRUE(viewer->wait_connected(10s));
  EXPECT_NE(urs("newbie", {"--timeout-ms", "1000", "ls"}).exit_code, 0);

  write_credentials({{"ops", "operator"}, {"sam-robot1", "sam"}, {"newbie", "client"}});
  server_->signal(SIGHUP);
  ASSERT_TRUE(urs::test::wait_until([&] { return urs("newbie", {"--timeout-ms", "1000", "ls"}).exit_code == 0; }, 20s));
  ASSERT_TRUE(urs::test::wait_until([&] { return viewer->last_error() == "refused: wrong token"; }, 20s))
      << viewer->last_error();
  EXPECT_FALSE(viewer->connected());
  EXPECT_TRUE(ops->connected());
  URS::Diagnostic_echo_Request echo;
  echo.set_text("after reload");
  EXPECT_TRUE(ops->call("diag", "echo", echo.SerializeAsString(), 10s).ok());
  EXPECT_THAT(server_->log(), HasSubstr("credential 'viewer' was changed or revoked"));

  write(dir_ + "/credentials.yaml", "credentials:\n  - name: ops\n    role: admin\n");
  server_->signal(SIGHUP);
  ASSERT_TRUE(urs::test::wait_until(
      [&] { return server_->log().find("SIGHUP: credentials not reloaded") != std::string::npos; }, 20s));
  EXPECT_THAT(server_->log(), HasSubstr("credentials[0].role: 'admin' is not client, sam or operator"));
  EXPECT_EQ(urs("newbie", {"--timeout-ms", "2000", "ls"}).exit_code, 0);
  EXPECT_TRUE(server_->running());
  viewer->stop();
  ops->stop();
}

// One piece of a chunked message, as a frame.
planet::Frame chunk_piece(uint64_t message_id, uint64_t total, uint64_t offset, size_t size) {
  planet::Frame frame;
  frame.mutable_chunk()->set_message_id(message_id);
  frame.mutable_chunk()->set_total_bytes(total);
  frame.mutable_chunk()->set_offset(offset);
  frame.mutable_chunk()->set_data(std::string(size, 'm'));
  frame.mutable_chunk()->set_last(offset + size == total);
  return frame;
}

// Three connections that never send Hello push half-finished chunked 64 MiB messages (this took
// the server from 183 MiB to 2.8 GiB before): each is refused at its first frame, before anything
// of the declared size is allocated. So are a chunk-wrapped Hello and a 64 MiB length prefix.
// Then an authenticated peer pushes chunked messages past the per-session reassembly budget,
// and connections from one address past max_connections_per_address.
TEST_F(TrustTest, MemoryBeforeTheHandshakeIsBoundedAndBudgetsHold) {
  begin_attack({"--max-reassembly-bytes", "67108864", "--max-connections-per-address", "24"});
  ASSERT_FALSE(HasFatalFailure());
  constexpr uint64_t kTotal = 64ull << 20;
  constexpr size_t kPiece = 60 * 1024;
  auto expect_hello_refusal = [&](RawPeer& raw, const std::string& who) {
    auto answer = raw.read_non_ping(10s);
    ASSERT_TRUE(answer && answer->has_goodbye()) << who << ": " << (answer ? answer->ShortDebugString() : "nothing");
    EXPECT_EQ(answer->goodbye().status(), planet::PAYLOAD_TOO_LARGE) << who;
    EXPECT_THAT(answer->goodbye().reason(), HasSubstr("(max_hello_bytes)")) << who;
    EXPECT_TRUE(raw.closed_by_server(10s)) << who;
  };
  {
    std::vector<std::unique_ptr<RawPeer>> attackers;
    std::vector<std::thread> pushers;
    for (int i = 0; i < 3; ++i) attackers.push_back(std::make_unique<RawPeer>(port_));
    for (auto& raw : attackers) {
      pushers.emplace_back([&raw] {
        // Half of the message; the sends fail once the server has closed the connection.
        for (uint64_t offset = 0; offset < kTotal / 2; offset += kPiece) {
          if (!raw->send_frame_checked(chunk_piece(7, kTotal, offset, kPiece))) return;
        }
      });
    }
    for (auto& pusher : pushers) pusher.join();
    sample_memory();
    for (size_t i = 0; i < attackers.size(); ++i) expect_hello_refusal(*attackers[i], "chunk attacker " + std::to_string(i));
  }
  {
    RawPeer wrapped(port_);
    planet::Frame hello;
    hello.mutable_hello()->set_version(1);
    hello.mutable_hello()->set_token(token_value("viewer"));
    hello.mutable_hello()->set_peer_name("wrapped");
    const std::string bytes = hello.SerializeAsString();
    planet::Frame chunk;
    chunk.mutable_chunk()->set_message_id(1);
    chunk.mutable_chunk()->set_total_bytes(bytes.size());
    chunk.mutable_chunk()->set_data(bytes);
    chunk.mutable_chunk()->set_last(true);
    wrapped.send_frame(chunk);
    expect_hello_refusal(wrapped, "chunk-wrapped Hello");
  }
  {
    RawPeer large(port_);
    std::string prefix;
    planet::append_length_prefix(prefix, static_cast<uint32_t>(kTotal));
    large.send_bytes(prefix + std::string(1024, '\0'));
    expect_hello_refusal(large, "64 MiB length prefix");
  }
  sample_memory();
  const long hello_peak = rss_peak_;
  EXPECT_LT(hello_peak - rss_before_, 64 * 1024) << "the attack before the handshake cost over 64 MiB";

  // After Welcome: three 64 MiB messages in progress at once outgrow max_reassembly_bytes 64 MiB.
  {
    RawPeer raw(port_);
    raw_hello(raw, "intruder");
    bool open = true;
    for (uint64_t offset = 0; open && offset < kTotal - kPiece; offset += kPiece) {
      for (uint64_t id = 1; open && id <= 3; ++id) open = raw.send_frame_checked(chunk_piece(id, kTotal, offset, kPiece));
      if (offset % (8 << 20) < kPiece) sample_memory();
    }
    auto goodbye = next(raw, planet::Frame::kGoodbye, 20s);
    ASSERT_TRUE(goodbye);
    EXPECT_EQ(goodbye->goodbye().status(), planet::RESOURCE_EXHAUSTED);
    EXPECT_THAT(goodbye->goodbye().reason(), HasSubstr("bytes (max_reassembly_bytes)"));
    EXPECT_TRUE(raw.closed_by_server(10s));
  }
  sample_memory();
  EXPECT_LT(rss_peak_ - rss_before_, 192 * 1024) << "a session held far more than max_reassembly_bytes";

  // Connections from one address: the legitimate client, the SAM and 22 more; the next is refused.
  {
    std::vector<std::unique_ptr<RawPeer>> idle;
    std::optional<planet::Frame> refused;
    for (int i = 0; i < 40 && !refused; ++i) {
      idle.push_back(std::make_unique<RawPeer>(port_));
      auto frame = idle.back()->read_frame(200ms);
      if (frame && frame->has_refused()) refused = frame;
    }
    ASSERT_TRUE(refused) << "40 connections from 127.0.0.1 were all accepted";
    EXPECT_EQ(refused->refused().status(), planet::RESOURCE_EXHAUSTED);
    EXPECT_THAT(refused->refused().reason(), HasSubstr("(max_connections_per_address 24)"));
    EXPECT_LE(idle.size(), 23u);
  }
  end_attack("before_handshake", {{"hello_attack_rss_peak_kib", static_cast<double>(hello_peak)}});
}

// 18,000 log lines in 20 s of fuzzing before: libprotobuf's own errors now go through spdlog and
// obey --log-level (off: nothing at all), and the warnings one address causes are rate-limited
// with a count of what was suppressed.
TEST_F(TrustTest, LibprotobufLogsObeyTheLogLevelAndPeerWarningsAreRateLimited) {
  // A Hello whose peer_name is not UTF-8: libprotobuf complains, the codec refuses the frame.
  const std::string hello = std::string("\x08\x01\x1a\x02\xff\xfe", 6);
  std::string frame = std::string(1, '\x0a') + static_cast<char>(hello.size()) + hello;
  std::string wire;
  planet::append_length_prefix(wire, static_cast<uint32_t>(frame.size()));
  wire += frame;
  for (const std::string level : {"off", "warn"}) {
    SCOPED_TRACE(level);
    const std::string port_file = dir_ + "/port-" + level;
    Process server({URS_CAMUS_SERVER_BIN, "--space", "kr", "--listen", "127.0.0.1:0", "--port-file", port_file,
                    "--log-level", level},
                   dir_ + "/server-" + level + ".log");
    ASSERT_TRUE(urs::test::wait_until([&] { return std::filesystem::exists(port_file); }, 20s));
    const auto port = static_cast<uint16_t>(std::stoi(urs::test::read_text(port_file)));
    for (int i = 0; i < 40; ++i) {
      RawPeer raw(port);
      raw.send_bytes(wire);
      EXPECT_TRUE(raw.closed_by_server(10s));
    }
    server.signal(SIGTERM);
    EXPECT_EQ(server.wait(20s), 0);
    const std::string log = server.log();
    if (level == "off") {
      EXPECT_EQ(log, "");
      continue;
    }
    auto count = [&](const std::string& text) {
      size_t n = 0;
      for (size_t at = log.find(text); at != std::string::npos; at = log.find(text, at + 1)) ++n;
      return n;
    };
    EXPECT_GE(count("libprotobuf"), 1u);
    EXPECT_LE(count("libprotobuf"), 10u) << "at most 10 libprotobuf messages per 10 s";
    EXPECT_LE(count("planet: closing"), 5u) << "at most 5 warnings per address per 10 s";
    EXPECT_LT(count("\n"), 40u) << log;
  }
}

}  // namespace
}  // namespace urs::camus_server::test
