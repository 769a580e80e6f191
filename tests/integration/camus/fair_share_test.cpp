// Fair shares of a space's budgets, attacked on loopback: one client credential ("mallory") does
// everything its role allows, on as many connections as it likes, against a real urs-camus-server
// with a real urs-sam (the diagnostic agent) and a legitimate client calling and receiving events
// throughout (space_under_attack.hpp). Each test shows the attacker refused with
// RESOURCE_EXHAUSTED naming the limit, and the others served. Budgets are configured small so
// that each attack takes seconds; the mechanism is the one the defaults use.

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <unistd.h>

#include <regex>

#include "space_under_attack.hpp"

namespace urs::camus_server::test {
namespace {

using ::testing::HasSubstr;

// A raw connection to 127.0.0.1:`port` from the loopback address `source` (127.0.0.2, ...).
std::unique_ptr<RawPeer> raw_from(const std::string& source, uint16_t port) {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in local{};
  local.sin_family = AF_INET;
  ::inet_pton(AF_INET, source.c_str(), &local.sin_addr);
  sockaddr_in remote{};
  remote.sin_family = AF_INET;
  remote.sin_port = htons(port);
  remote.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (fd < 0 || ::bind(fd, reinterpret_cast<sockaddr*>(&local), sizeof local) != 0 ||
      ::connect(fd, reinterpret_cast<sockaddr*>(&remote), sizeof remote) != 0) {
    if (fd >= 0) ::close(fd);
    return nullptr;
  }
  return std::make_unique<RawPeer>(fd);
}

// The first frame of `kind` within `timeout` (Pings and others skipped), if any.
std::optional<planet::Frame> first_of(RawPeer& raw, planet::Frame::BodyCase kind, std::chrono::milliseconds timeout) {
  const auto deadline = Clock::now() + timeout;
  while (Clock::now() < deadline) {
    auto frame = raw.read_frame(std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()));
    if (!frame) return std::nullopt;
    if (frame->body_case() == kind) return frame;
  }
  return std::nullopt;
}

planet::Frame subscribe_frame(uint64_t id, const std::string& pattern) {
  planet::Frame frame;
  frame.mutable_subscribe()->set_subscription_id(id);
  frame.mutable_subscribe()->set_pattern(pattern);
  return frame;
}

class FairShareTest : public TrustTest {
 protected:
  // `count` sessions of `who` over raw connections (each with its Welcome).
  std::vector<std::unique_ptr<RawPeer>> sessions_of(const std::string& who, size_t count) {
    std::vector<std::unique_ptr<RawPeer>> out;
    for (size_t i = 0; i < count; ++i) {
      out.push_back(std::make_unique<RawPeer>(port_));
      raw_hello(*out.back(), who, planet::CLIENT, "", who + "-" + std::to_string(i));
    }
    return out;
  }
};

// Item 1: one client credential on 9 sessions, each within its own per-session limit (two
// chunked messages in progress, 2 MiB), fills the server's buffers (16 MiB; the clients' pool is
// 80% of it). Its session that passes its fair share is closed with RESOURCE_EXHAUSTED naming
// max_buffered_bytes; the SAM, the legitimate client and new connections go on.
TEST_F(FairShareTest, OneClientCredentialCannotTakeTheBufferBudget) {
  begin_attack({"--max-message-bytes", "1048576", "--max-reassembly-bytes", "2097152", "--max-send-queue-bytes",
                "2097152", "--max-buffered-bytes", "16777216", "--heartbeat-timeout-ms", "60000"});
  ASSERT_FALSE(HasFatalFailure());
  constexpr uint64_t kTotal = 1 << 20;
  constexpr size_t kPiece = 60 * 1024;
  auto attackers = sessions_of("mallory", 9);
  for (auto& raw : attackers) {
    bool open = true;
    for (uint64_t offset = 0; open && offset + kPiece < kTotal; offset += kPiece) {
      for (uint64_t id = 1; open && id <= 2; ++id)
        open = raw->send_frame_checked(chunk_piece(id, kTotal, offset, kPiece));
    }
    sample_memory();
  }
  std::vector<planet::Goodbye> goodbyes;
  for (auto& raw : attackers) {
    if (auto goodbye = first_of(*raw, planet::Frame::kGoodbye, 500ms)) goodbyes.push_back(goodbye->goodbye());
  }
  ASSERT_FALSE(goodbyes.empty()) << "the attacker held 18 MiB of a 16 MiB budget";
  EXPECT_LT(goodbyes.size(), attackers.size());
  for (const auto& goodbye : goodbyes) {
    EXPECT_EQ(goodbye.status(), planet::RESOURCE_EXHAUSTED);
    EXPECT_THAT(goodbye.reason(), HasSubstr("(max_buffered_bytes 16777216 less the 3355443 kept for sam and operator"));
    EXPECT_THAT(goodbye.reason(), HasSubstr("credential 'mallory' holds"));
    EXPECT_THAT(goodbye.reason(), HasSubstr("over its fair share"));
  }
  // While the attacker holds what it got: the others are served, and a newcomer is admitted.
  const size_t before = legit_->calls();
  ASSERT_TRUE(urs::test::wait_until([&] { return legit_->calls() >= before + 20; }, 20s));
  auto whoami = urs("viewer", {"whoami"});
  EXPECT_EQ(whoami.exit_code, 0) << whoami.err;
  EXPECT_EQ(whoami.out, "viewer client kr\n");
  end_attack("buffer_share", {{"attacker_sessions_closed", static_cast<double>(goodbyes.size())}});
}

// Item 2: one client credential on 11 connections asks for more calls (diag.sleep, 60 s
// deadline) than the server holds (100). It is refused beyond its fair share; the legitimate
// client's calls, a registry call and an operator's call still go through.
TEST_F(FairShareTest, OneClientCredentialCannotHoldEveryPendingCall) {
  begin_attack(
      {"--max-pending-calls", "100", "--max-pending-calls-per-session", "10", "--heartbeat-timeout-ms", "60000"});
  ASSERT_FALSE(HasFatalFailure());
  URS::Diagnostic_sleep_Request sleep;
  sleep.set_ms(30000);
  auto attackers = sessions_of("mallory", 11);
  for (auto& raw : attackers) {
    for (uint64_t id = 1; id <= 10; ++id)
      raw->send_frame(request(id, "diag", "sleep", sleep.SerializeAsString(), 60000));
  }
  std::vector<std::string> refusals;
  for (auto& raw : attackers) {
    while (auto reply = first_of(*raw, planet::Frame::kReply, 300ms)) {
      EXPECT_EQ(reply->reply().status(), planet::RESOURCE_EXHAUSTED) << reply->reply().message();
      refusals.push_back(reply->reply().message());
    }
  }
  // 100 less the 20 kept for sam and operator sessions: about 80 held (the legitimate client's
  // call in flight counts in the same pool), 30 refused.
  EXPECT_GE(refusals.size(), 30u);
  EXPECT_LE(refusals.size(), 32u);
  ASSERT_FALSE(refusals.empty());
  EXPECT_THAT(refusals.back(),
              HasSubstr("calls pending for client credentials, its limit (max_pending_calls 100 less the 20 kept for "
                        "sam and operator sessions, reserved_percent 20); credential 'mallory' holds"));
  EXPECT_THAT(refusals.back(), HasSubstr("over its fair share"));
  // The others: calls of the legitimate client (running throughout), a registry call and an
  // operator's call.
  const size_t before = legit_->calls();
  ASSERT_TRUE(urs::test::wait_until([&] { return legit_->calls() >= before + 20; }, 20s));
  EXPECT_EQ(urs("viewer", {"ls", "diag"}).exit_code, 0);
  auto ops = client("ops", planet::OPERATOR);
  ops->start();
  ASSERT_TRUE(ops->wait_connected(10s));
  URS::Diagnostic_echo_Request echo;
  echo.set_text("operator");
  auto answered = ops->call("diag", "echo", echo.SerializeAsString(), 10s);
  EXPECT_TRUE(answered.ok()) << answered.message;
  ops->stop();
  end_attack("pending_call_share", {{"attacker_refused", static_cast<double>(refusals.size())}});
}

// Item 3: one client credential on 11 connections asks for more subscriptions than the server
// holds (200). It is refused beyond its fair share; the legitimate client still subscribes (and
// receives), and so does an operator.
TEST_F(FairShareTest, OneClientCredentialCannotTakeEverySubscription) {
  begin_attack(
      {"--max-subscriptions", "200", "--max-subscriptions-per-session", "20", "--heartbeat-timeout-ms", "60000"});
  ASSERT_FALSE(HasFatalFailure());
  auto attackers = sessions_of("mallory", 11);
  for (auto& raw : attackers) {
    for (uint64_t id = 1; id <= 20; ++id) raw->send_frame(subscribe_frame(id, "mallory/" + std::to_string(id) + "/#"));
  }
  size_t accepted = 0;
  std::vector<std::string> refusals;
  for (auto& raw : attackers) {
    for (int i = 0; i < 20; ++i) {
      auto ack = next(*raw, planet::Frame::kSubscribeAck, 10s);
      ASSERT_TRUE(ack);
      if (ack->subscribe_ack().status() == planet::OK) {
        ++accepted;
      } else {
        EXPECT_EQ(ack->subscribe_ack().status(), planet::RESOURCE_EXHAUSTED);
        refusals.push_back(ack->subscribe_ack().message());
      }
    }
  }
  // 200 less the 40 kept for sam and operator sessions, less the legitimate client's one.
  EXPECT_EQ(accepted, 159u);
  ASSERT_EQ(refusals.size(), 61u);
  EXPECT_THAT(refusals.back(), HasSubstr("the server holds 160 subscriptions for client credentials, its limit "
                                         "(max_subscriptions 200 less the 40 kept for sam and operator sessions"));
  EXPECT_THAT(refusals.back(), HasSubstr("credential 'mallory' holds 159, over its fair share of 80"));
  const size_t before = legit_->calls();
  ASSERT_TRUE(urs::test::wait_until([&] { return legit_->calls() >= before + 20; }, 20s));
  for (const std::string who : {"viewer", "ops"}) {
    auto watcher = client(who);
    watcher->start();
    ASSERT_TRUE(watcher->wait_connected(10s));
    std::mutex mutex;
    std::condition_variable cv;
    size_t seen = 0;
    for (int i = 0; i < 10; ++i) {
      watcher->subscribe("kr/" + who + "/" + std::to_string(i), [&](const planet::Event&) {
        std::lock_guard<std::mutex> lock(mutex);
        ++seen;
        cv.notify_all();
      });
    }
    // Subscriptions are sent before later publishes on the connection: each is in place.
    for (int i = 0; i < 10; ++i) {
      auto published =
          watcher->publish_and_wait("kr/" + who + "/" + std::to_string(i), "x", "text/plain", std::chrono::seconds(10));
      EXPECT_TRUE(published.ok()) << published.message;
    }
    std::unique_lock<std::mutex> lock(mutex);
    EXPECT_TRUE(cv.wait_for(lock, 10s, [&] { return seen == 10; })) << who << " received " << seen;
    lock.unlock();
    watcher->stop();
  }
  end_attack("subscription_share", {{"attacker_refused", static_cast<double>(refusals.size())}});
}

// Item 4: the server raises its descriptor limit to the hard limit and sizes max_connections
// from what is left. One client credential connects from two addresses until refused; a client
// from a third address still gets its Welcome at once, and so do an operator and the SAM.
TEST_F(FairShareTest, DescriptorsBoundTheConnectionsAndOneCredentialCannotTakeThemAll) {
  server_prefix_ = {"/usr/bin/prlimit", "--nofile=128:400", "--"};
  begin_attack({"--heartbeat-timeout-ms", "60000"});
  ASSERT_FALSE(HasFatalFailure());
  std::vector<std::unique_ptr<RawPeer>> held;
  std::optional<planet::Refused> refused;
  for (size_t i = 0; i < 400 && !refused; ++i) {
    auto raw = raw_from(i % 2 == 0 ? "127.0.0.2" : "127.0.0.3", port_);
    ASSERT_TRUE(raw) << "connection " << i;
    raw->send_hello(1, token_value("mallory"), "mallory");
    auto answer = raw->read_non_ping(10s);
    ASSERT_TRUE(answer) << "no answer to connection " << i;
    if (answer->has_refused()) refused = answer->refused();
    held.push_back(std::move(raw));
  }
  ASSERT_TRUE(refused) << "one client credential opened " << held.size() << " sessions";
  EXPECT_THAT(server_->log(), HasSubstr("(file descriptor limit 400, raised to the hard limit)"));
  std::smatch match;
  const std::string log = server_->log();
  ASSERT_TRUE(std::regex_search(log, match, std::regex("max_connections lowered from 10000 to ([0-9]+)"))) << log;
  const size_t max_connections = std::stoul(match[1].str());
  EXPECT_GT(max_connections, 200u);
  EXPECT_LT(max_connections, 400u);
  EXPECT_EQ(refused->status(), planet::RESOURCE_EXHAUSTED);
  EXPECT_THAT(refused->reason(), HasSubstr("session not opened: the server holds"));
  EXPECT_THAT(refused->reason(), HasSubstr("(max_connections " + std::to_string(max_connections)));
  EXPECT_THAT(refused->reason(), HasSubstr("credential 'mallory' holds"));
  for (const auto& [who, from] :
       std::vector<std::pair<std::string, std::string>>{{"viewer", "127.0.0.4"}, {"ops", "127.0.0.5"}}) {
    auto raw = raw_from(from, port_);
    ASSERT_TRUE(raw);
    const auto start = Clock::now();
    raw->send_hello(1, token_value(who), who);
    auto answer = raw->read_non_ping(2s);
    ASSERT_TRUE(answer && answer->has_welcome()) << who << ": " << (answer ? answer->ShortDebugString() : "nothing");
    figure("descriptors_" + who,
           {{"welcome_ms", std::chrono::duration<double, std::milli>(Clock::now() - start).count()}});
  }
  end_attack("descriptors", {{"max_connections", static_cast<double>(max_connections)},
                             {"attacker_sessions", static_cast<double>(held.size() - 1)}});
}

// Item 5: the credentials file replaced by a directory, then by a FIFO nobody writes: each SIGHUP
// is refused with the reason, the previous credentials stay in force, sessions go on, and
// SIGTERM still stops the server at once.
TEST_F(FairShareTest, ReloadNeverStopsNorWedgesTheServer) {
  start_space();
  ASSERT_FALSE(HasFatalFailure());
  auto viewer = client("viewer");
  viewer->start();
  ASSERT_TRUE(viewer->wait_connected(10s));
  const std::string file = dir_ + "/credentials.yaml";
  std::filesystem::rename(file, dir_ + "/credentials.kept");
  std::filesystem::create_directory(file);
  server_->signal(SIGHUP);
  ASSERT_TRUE(urs::test::wait_until(
      [&] { return server_->log().find("is a directory, not a regular file") != std::string::npos; }, 20s))
      << server_->log();
  EXPECT_THAT(server_->log(), HasSubstr("SIGHUP: credentials not reloaded, the previous ones stay in force"));
  EXPECT_TRUE(server_->running());
  std::filesystem::remove(file);
  ASSERT_EQ(::mkfifo(file.c_str(), 0600), 0);
  server_->signal(SIGHUP);
  ASSERT_TRUE(urs::test::wait_until(
      [&] { return server_->log().find("is a FIFO, not a regular file") != std::string::npos; }, 20s))
      << server_->log();
  // The previous credentials hold: the open session goes on, a new handshake is admitted.
  URS::Diagnostic_echo_Request echo;
  echo.set_text("after two broken reloads");
  auto answered = viewer->call("diag", "echo", echo.SerializeAsString(), 10s);
  EXPECT_TRUE(answered.ok()) << answered.message;
  auto whoami = urs("viewer", {"whoami"});
  EXPECT_EQ(whoami.exit_code, 0) << whoami.err;
  viewer->stop();
  server_->signal(SIGTERM);
  EXPECT_EQ(server_->wait(10s), 0) << server_->log();
}

// Item 6: a task's publish step publishes as the task's owner under the topic rules of any peer:
// a step on a server topic is refused when the task is defined (or run inline), and what a task
// publishes carries its owner as the source, never camus-server.
TEST_F(FairShareTest, ATaskPublishesAsItsOwnerNeverAsTheServer) {
  start_space();
  ASSERT_FALSE(HasFatalFailure());
  auto watcher = client("viewer");
  std::mutex mutex;
  std::condition_variable cv;
  std::vector<planet::Event> seen;
  watcher->start();
  ASSERT_TRUE(watcher->wait_connected(10s));
  for (const std::string pattern : {"registry/#", "kr/#"}) {
    watcher->subscribe(pattern, [&](const planet::Event& e) {
      std::lock_guard<std::mutex> lock(mutex);
      seen.push_back(e);
      cv.notify_all();
    });
  }
  // Subscriptions are in place once this publish came back.
  ASSERT_TRUE(watcher->publish_and_wait("kr/ready", "x", "text/plain", 10s).ok());
  write(dir_ + "/forge.yaml",
        "name: forge\n"
        "steps:\n"
        "  - publish: {topic: registry/diag, type: urs.camus.ServiceInfo, payload: {name: diag, state: gone, owner: "
        "camus-server}}\n");
  auto defined = urs("ops", {"task", "define", dir_ + "/forge.yaml"});
  EXPECT_NE(defined.exit_code, 0);
  EXPECT_THAT(defined.err, HasSubstr("BAD_ARGUMENTS"));
  EXPECT_THAT(defined.err, HasSubstr("topics under 'registry/' are published by the server alone"));
  auto inline_run = urs("ops", {"task", "run", "--file", dir_ + "/forge.yaml"});
  EXPECT_NE(inline_run.exit_code, 0);
  write(dir_ + "/door.yaml",
        "name: door\n"
        "steps:\n"
        "  - publish: {topic: kr/door, type: urs.camus.ServiceInfo, payload: {name: door, state: open}}\n");
  auto ran = urs("ops", {"task", "run", "--file", dir_ + "/door.yaml", "--wait"});
  EXPECT_EQ(ran.exit_code, 0) << ran.err;
  std::unique_lock<std::mutex> lock(mutex);
  ASSERT_TRUE(cv.wait_for(lock, 10s, [&] {
    return std::any_of(seen.begin(), seen.end(), [](const planet::Event& e) { return e.topic() == "kr/door"; });
  }));
  for (const auto& event : seen) {
    if (event.topic() == "kr/door") {
      EXPECT_EQ(event.source(), "ops");
    }
    camus::ServiceInfo info;
    if (event.topic() == "registry/diag" && info.ParseFromString(event.payload())) {
      EXPECT_NE(info.state(), "gone") << "a forged registry event: " << event.ShortDebugString();
    }
  }
  lock.unlock();
  watcher->stop();
}

// Item 7: connection churn by one credential (more closed sessions than the server keeps) never
// evicts another's session: the victim resumes it and its resent event is not delivered twice.
// A session its own credential's churn evicted answers the resend ALREADY_EXISTS, saying so.
TEST_F(FairShareTest, ChurnByAStrangerNeverEvictsASessionAndAnEvictedResendIsRefused) {
  begin_attack({"--max-resumable-sessions", "60", "--max-resumable-sessions-per-credential", "20"});
  ASSERT_FALSE(HasFatalFailure());
  auto counter = client("ops");
  std::mutex mutex;
  std::condition_variable cv;
  std::vector<planet::Event> delivered;
  counter->start();
  ASSERT_TRUE(counter->wait_connected(10s));
  counter->subscribe("kr/victim/#", [&](const planet::Event& e) {
    std::lock_guard<std::mutex> lock(mutex);
    delivered.push_back(e);
    cv.notify_all();
  });
  ASSERT_TRUE(counter->publish_and_wait("kr/victim/ready", "x", "text/plain", 10s).ok());
  auto publish = [](uint64_t id) {
    planet::Frame frame;
    frame.mutable_publish()->set_publish_id(id);
    frame.mutable_publish()->set_topic("kr/victim/event");
    frame.mutable_publish()->set_payload("payload " + std::to_string(id));
    return frame;
  };
  auto deliveries = [&](const std::string& payload, size_t at_least) {
    std::unique_lock<std::mutex> lock(mutex);
    cv.wait_for(lock, 2s, [&] {
      return static_cast<size_t>(std::count_if(delivered.begin(), delivered.end(), [&](const planet::Event& e) {
               return e.payload() == payload;
             })) > at_least;
    });
    return std::count_if(delivered.begin(), delivered.end(),
                         [&](const planet::Event& e) { return e.payload() == payload; });
  };
  std::string secret;
  {
    RawPeer victim(port_);
    secret = raw_hello(victim, "viewer", planet::CLIENT, "", "victim").session_secret();
    victim.send_frame(publish(1));
    auto ack = next(victim, planet::Frame::kPublishAck);
    ASSERT_TRUE(ack);
    ASSERT_EQ(ack->publish_ack().status(), planet::OK);
  }
  // A stranger churns through ten times the sessions the server keeps per credential.
  for (int i = 0; i < 200; ++i) {
    RawPeer churn(port_);
    raw_hello(churn, "mallory", planet::CLIENT, "", "churn");
  }
  {
    RawPeer victim(port_);
    const auto welcome = raw_hello(victim, "viewer", planet::CLIENT, secret, "victim");
    EXPECT_EQ(welcome.session_secret(), secret) << "the victim's session was evicted by a stranger's churn";
    victim.send_frame(publish(1));  // its resend after the reconnect
    auto ack = next(victim, planet::Frame::kPublishAck);
    ASSERT_TRUE(ack);
    EXPECT_EQ(ack->publish_ack().status(), planet::OK);
  }
  EXPECT_EQ(deliveries("payload 1", 1), 1) << "the resent event was delivered twice";
  // The victim's own churn evicts its own oldest session; resending on it is refused, saying so.
  for (int i = 0; i < 30; ++i) {
    RawPeer churn(port_);
    raw_hello(churn, "viewer", planet::CLIENT, "", "own-churn");
  }
  {
    RawPeer victim(port_);
    const auto welcome = raw_hello(victim, "viewer", planet::CLIENT, secret, "victim");
    EXPECT_NE(welcome.session_secret(), secret);
    victim.send_frame(publish(1));
    auto ack = next(victim, planet::Frame::kPublishAck);
    ASSERT_TRUE(ack);
    EXPECT_EQ(ack->publish_ack().status(), planet::ALREADY_EXISTS);
    EXPECT_THAT(ack->publish_ack().message(), HasSubstr("publish_id 1 was received by session"));
    EXPECT_THAT(ack->publish_ack().message(), HasSubstr("which this server no longer keeps"));
    victim.send_frame(publish(2));  // a new one goes through
    ack = next(victim, planet::Frame::kPublishAck);
    ASSERT_TRUE(ack);
    EXPECT_EQ(ack->publish_ack().status(), planet::OK);
  }
  EXPECT_EQ(deliveries("payload 1", 1), 1) << "the resend on an evicted session was delivered twice";
  EXPECT_EQ(deliveries("payload 2", 0), 1);
  counter->stop();
  end_attack("session_churn");
}

}  // namespace
}  // namespace urs::camus_server::test
