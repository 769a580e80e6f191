// One service, two providers: a real urs-camus-server with named credentials and two real urs-sam
// processes of one credential hosting the diagnostic agent under the same name. The server lists
// one service with two providers, routes each call to one of them, and when one is killed fails
// only the calls that one held (PROVIDER_GONE; nothing is sent twice) while the other serves every
// call after; a SAM that stops cleanly leaves without a failed call. Nobody holding another
// credential, whatever its role, can add itself as a provider, and no one registers the name with
// another interface.

#include <gmock/gmock.h>
#include <google/protobuf/util/json_util.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <unistd.h>

#include <atomic>
#include <condition_variable>
#include <filesystem>
#include <fstream>
#include <future>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "Diagnostic.pb.h"
#include "camus.pb.h"
#include "process.hpp"
#include "urs/planet/client.hpp"

namespace urs::camus_server::test {
namespace {

using namespace std::chrono_literals;
using ::testing::HasSubstr;
using urs::test::Process;

class ProvidersTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = urs::test::make_temp_dir("providers");
    for (const char* name : {"sam", "ops", "viewer", "intruder"}) {
      write(dir_ + "/" + name + ".token", std::string(name) + "-" + std::to_string(::getpid()) + "-token\n");
    }
    write(dir_ + "/credentials.yaml",
          "credentials:\n"
          "  - {name: sam, role: sam, token_file: sam.token}\n"
          "  - {name: ops, role: operator, token_file: ops.token}\n"
          "  - {name: viewer, role: client, token_file: viewer.token}\n"
          "  - {name: intruder, role: sam, token_file: intruder.token}\n");
    for (const char* peer : {"sam-a", "sam-b", "sam-c"}) {
      write(dir_ + "/" + peer + ".yaml", std::string("name: ") + peer +
                                             "\n"
                                             "agents:\n"
                                             "  - name: diag\n"
                                             "    type: diagnostic\n"
                                             "    deadline_ms: 5000\n");
    }
    server_ = std::make_unique<Process>(
        std::vector<std::string>{URS_CAMUS_SERVER_BIN, "--space", "kr", "--listen", "127.0.0.1:0", "--port-file",
                                 dir_ + "/port", "--credentials", dir_ + "/credentials.yaml", "--log-level", "debug"},
        dir_ + "/server.log");
    ASSERT_TRUE(urs::test::wait_until([&] { return std::filesystem::exists(dir_ + "/port"); }, 20s)) << server_->log();
    port_ = static_cast<uint16_t>(std::stoi(urs::test::read_text(dir_ + "/port")));
    viewer_ = client("viewer");
    // Every registry event from the start: what changed for diag, in order.
    viewer_->subscribe("registry/diag", [this](const planet::Event& event) {
      camus::ServiceInfo info;
      ASSERT_TRUE(info.ParseFromString(event.payload()));
      std::lock_guard<std::mutex> lock(mutex_);
      changes_.push_back(info.change() + "/" + info.state() + "/" + std::to_string(info.providers_size()));
      changed_.notify_all();
    });
    ASSERT_TRUE(viewer_->wait_connected(10s));
    // The subscription is in place once the server answers a call made after it.
    ASSERT_EQ(list("diag").services_size(), 0);
  }

  void TearDown() override {
    if (HasFailure()) {
      std::cerr << "---- server log (tail)\n" << tail(server_ ? server_->log() : "");
      for (const auto& [peer, sam] : sams_) std::cerr << "---- " << peer << " log (tail)\n" << tail(sam->log());
    }
    viewer_.reset();
    sams_.clear();
    server_.reset();
    std::filesystem::remove_all(dir_);
  }

  static std::string tail(const std::string& text) {
    return text.size() > 6000 ? text.substr(text.size() - 6000) : text;
  }
  static void write(const std::string& path, const std::string& text) { std::ofstream(path) << text; }
  std::string address() const { return "127.0.0.1:" + std::to_string(port_); }
  std::string token(const std::string& who) const {
    std::string t = urs::test::read_text(dir_ + "/" + who + ".token");
    t.erase(t.find_last_not_of(" \n") + 1);
    return t;
  }

  std::unique_ptr<planet::Client> client(const std::string& who, planet::Role role = planet::CLIENT) {
    planet::ClientOptions options;
    options.port = port_;
    options.token = token(who);
    options.peer_name = who;
    options.role = role;
    auto c = std::make_unique<planet::Client>(options);
    c->start();
    return c;
  }

  // A SAM named `peer` (its declared name) hosting diag, authenticated as `who`.
  Process& start_sam(const std::string& peer, const std::string& who = "sam") {
    sams_[peer] =
        std::make_unique<Process>(std::vector<std::string>{URS_SAM_BIN, "--space", "kr", "--server", address(),
                                                           "--config", dir_ + "/" + peer + ".yaml", "--token-file",
                                                           dir_ + "/" + who + ".token", "--log-level", "debug"},
                                  dir_ + "/" + peer + ".log");
    return *sams_[peer];
  }

  camus::ListReply list(const std::string& pattern) {
    camus::ListRequest request;
    request.set_pattern(pattern);
    auto result = viewer_->call("camus.registry", "List", request.SerializeAsString(), 10s);
    camus::ListReply reply;
    EXPECT_TRUE(result.ok()) << result.message;
    EXPECT_TRUE(reply.ParseFromString(result.payload));
    return reply;
  }

  // The peer names of diag's providers, in order ("" when there is no diag).
  std::string diag_peers() {
    auto reply = list("diag");
    std::string peers;
    for (const auto& service : reply.services()) {
      for (const auto& provider : service.providers()) peers += (peers.empty() ? "" : ",") + provider.peer_name();
    }
    return peers;
  }

  bool wait_for_peers(const std::string& peers) {
    return urs::test::wait_until([&] { return diag_peers() == peers; }, 20s);
  }

  planet::CallResult echo(planet::Client& from, const std::string& text, std::chrono::milliseconds deadline = 2s) {
    URS::Diagnostic_echo_Request request;
    request.set_text(text);
    return from.call("diag", "echo", request.SerializeAsString(), deadline);
  }

  std::vector<std::string> changes() {
    std::lock_guard<std::mutex> lock(mutex_);
    return changes_;
  }

  std::string dir_;
  uint16_t port_ = 0;
  std::unique_ptr<Process> server_;
  std::map<std::string, std::unique_ptr<Process>> sams_;
  std::unique_ptr<planet::Client> viewer_;
  std::mutex mutex_;
  std::condition_variable changed_;
  std::vector<std::string> changes_;
};

TEST_F(ProvidersTest, TwoSamsOfOneCredentialAreOneServiceAndWhenOneIsKilledTheOtherServesEveryCall) {
  start_sam("sam-a");
  ASSERT_TRUE(wait_for_peers("sam-a"));
  start_sam("sam-b");
  ASSERT_TRUE(wait_for_peers("sam-a,sam-b")) << diag_peers();
  auto listed = list("diag");
  ASSERT_EQ(listed.services_size(), 1) << "one service, not one per SAM";
  EXPECT_EQ(listed.services(0).owner(), "sam");
  EXPECT_EQ(listed.services(0).peer_name(), "sam-a");

  // `urs ls` shows both providers on diag's one line.
  auto ls = urs::test::run_command(
      {URS_CLI_BIN, "--server", address(), "--token-file", dir_ + "/viewer.token", "ls", "diag"}, 30s);
  ASSERT_EQ(ls.exit_code, 0) << ls.err;
  EXPECT_THAT(ls.out, ::testing::ContainsRegex("\ndiag +URS.Diagnostic +sam +sam-a,sam-b +available +native"))
      << ls.out;

  // Four long calls: two held by each SAM (the fewest pending gets the next one).
  auto caller = client("viewer");
  ASSERT_TRUE(caller->wait_connected(10s));
  std::vector<std::future<planet::CallResult>> sleeping;
  for (int i = 0; i < 4; ++i) {
    sleeping.push_back(std::async(std::launch::async, [&] {
      URS::Diagnostic_sleep_Request request;
      request.set_ms(3000);
      return caller->call("diag", "sleep", request.SerializeAsString(), 20s);
    }));
  }
  // Each SAM holds its two before sam-a is killed (a call still on its way would go to sam-b).
  auto sleeping_at = [&](const std::string& peer) {
    const std::string log = sams_[peer]->log();
    std::size_t n = 0;
    for (auto at = log.find("sleep 3000 ms begins"); at != std::string::npos;
         at = log.find("sleep 3000 ms begins", at + 1))
      ++n;
    return n;
  };
  ASSERT_TRUE(urs::test::wait_until([&] { return sleeping_at("sam-a") == 2 && sleeping_at("sam-b") == 2; }, 10s))
      << sleeping_at("sam-a") << " and " << sleeping_at("sam-b") << " calls begun at sam-a and sam-b";
  // Oneway notifies, each publishing one event of its own text where it runs: counted below, none
  // may arrive twice, whatever happens to the SAM that got it.
  std::map<std::string, int> executions;
  std::mutex executions_mutex;
  viewer_->subscribe("count/#", [&](const planet::Event& event) {
    URS::Diagnostic_notify_Request notified;
    ASSERT_TRUE(notified.ParseFromString(event.payload()));
    std::lock_guard<std::mutex> lock(executions_mutex);
    ++executions[notified.text()];
  });
  auto notify = [&](int i) {
    URS::Diagnostic_notify_Request request;
    request.set_topic("count/n");
    request.set_text("n" + std::to_string(i));
    ASSERT_TRUE(caller->oneway("diag", "notify", request.SerializeAsString()));
  };
  for (int i = 0; i < 50; ++i) notify(i);
  sams_["sam-a"]->kill9();

  // Each call sam-a held ends PROVIDER_GONE, the two at sam-b succeed.
  int gone = 0, served = 0;
  for (auto& call : sleeping) {
    auto result = call.get();
    if (result.status == planet::PROVIDER_GONE) {
      ++gone;
      EXPECT_EQ(result.message, "provider sam of diag disconnected");
    } else {
      EXPECT_TRUE(result.ok()) << planet::status_name(result.status) << " " << result.message;
      ++served;
    }
  }
  EXPECT_EQ(gone, 2);
  EXPECT_EQ(served, 2);

  // Every call after is served by sam-b, and the service never left.
  ASSERT_TRUE(wait_for_peers("sam-b")) << diag_peers();
  for (int i = 0; i < 20; ++i) {
    auto result = echo(*caller, "after " + std::to_string(i));
    ASSERT_TRUE(result.ok()) << planet::status_name(result.status) << " " << result.message;
  }
  for (int i = 50; i < 100; ++i) notify(i);
  ASSERT_TRUE(echo(*caller, "last").ok());  // the notifies before it have run
  auto all_executed_after_the_kill = [&] {
    std::lock_guard<std::mutex> lock(executions_mutex);
    for (int i = 50; i < 100; ++i) {
      if (executions.count("n" + std::to_string(i)) == 0) return false;
    }
    return true;
  };
  ASSERT_TRUE(urs::test::wait_until(all_executed_after_the_kill, 20s)) << "a notify sent after the kill was lost";
  {
    std::lock_guard<std::mutex> lock(executions_mutex);
    for (const auto& [text, count] : executions) EXPECT_EQ(count, 1) << text << " was executed " << count << " times";
  }
  EXPECT_EQ(changes(), (std::vector<std::string>{"registered/available/1", "provider-added/available/2",
                                                 "provider-removed/available/1"}))
      << "diag must never be announced gone while sam-b provides it";

  // The last provider goes: now the service is gone.
  sams_["sam-b"]->kill9();
  ASSERT_TRUE(wait_for_peers(""));
  EXPECT_EQ(echo(*caller, "nobody").status, planet::UNKNOWN_SERVICE);
  ASSERT_TRUE(urs::test::wait_until([&] { return changes().size() == 4; }, 10s));
  EXPECT_EQ(changes().back(), "disconnected/gone/0");
}

TEST_F(ProvidersTest, ASamStoppingCleanlyLeavesItsServiceToTheOtherWithoutAFailedCall) {
  start_sam("sam-a");
  ASSERT_TRUE(wait_for_peers("sam-a"));
  start_sam("sam-b");
  ASSERT_TRUE(wait_for_peers("sam-a,sam-b"));
  auto caller = client("viewer");
  ASSERT_TRUE(caller->wait_connected(10s));
  // Four callers without pause, two of them with calls that take a while: at any time some are
  // on their way to sam-a or running there.
  std::atomic<bool> stop{false};
  std::mutex failures_mutex;
  std::vector<std::string> failures;
  std::atomic<int> calls{0};
  std::vector<std::thread> calling;
  for (int t = 0; t < 4; ++t) {
    calling.emplace_back([&, t] {
      while (!stop) {
        planet::CallResult result;
        if (t % 2 == 0) {
          result = echo(*caller, "on and on");
        } else {
          URS::Diagnostic_sleep_Request request;
          request.set_ms(50);
          result = caller->call("diag", "sleep", request.SerializeAsString(), 2s);
        }
        if (!result.ok()) {
          std::lock_guard<std::mutex> lock(failures_mutex);
          failures.push_back(std::string(planet::status_name(result.status)) + " " + result.message);
        }
        ++calls;
      }
    });
  }
  ASSERT_TRUE(urs::test::wait_until([&] { return calls > 50; }, 20s));
  sams_["sam-a"]->signal(SIGTERM);
  EXPECT_EQ(sams_["sam-a"]->wait(20s), 0);
  const int at_stop = calls;
  ASSERT_TRUE(urs::test::wait_until([&] { return calls > at_stop + 50; }, 20s));
  stop = true;
  for (auto& thread : calling) thread.join();
  EXPECT_TRUE(failures.empty()) << failures.size() << " failed calls, the first: " << failures.front();
  EXPECT_EQ(diag_peers(), "sam-b");
  EXPECT_EQ(changes(), (std::vector<std::string>{"registered/available/1", "provider-added/available/2",
                                                 "provider-removed/available/1"}));
}

TEST_F(ProvidersTest, NoOtherCredentialMayProvideTheServiceNorAnyoneWithAnotherInterface) {
  start_sam("sam-a");
  ASSERT_TRUE(wait_for_peers("sam-a"));

  // A SAM of another credential with the same configuration: refused, it serves nothing.
  auto& intruder = start_sam("sam-c", "intruder");
  ASSERT_TRUE(urs::test::wait_until(
      [&] { return intruder.log().find("registering service diag failed") != std::string::npos; }, 20s))
      << intruder.log();
  EXPECT_THAT(intruder.log(), HasSubstr("registering service diag failed: ALREADY_EXISTS: service diag is provided "
                                        "by sam; only sessions of that credential may provide it too"));

  // Nor an operator, which may register services of its own.
  auto ops = client("ops", planet::OPERATOR);
  ASSERT_TRUE(ops->wait_connected(10s));
  camus::RegisterRequest registration;
  registration.mutable_service()->set_name("diag");
  registration.mutable_service()->set_interface("URS.Diagnostic");
  auto refused = ops->call("camus.registry", "Register", registration.SerializeAsString(), 10s);
  EXPECT_EQ(refused.status, planet::ALREADY_EXISTS);
  EXPECT_EQ(refused.message, "service diag is provided by sam; only sessions of that credential may provide it too");

  // The same credential with another interface under the name.
  auto same = client("sam", planet::SAM);
  ASSERT_TRUE(same->wait_connected(10s));
  registration.mutable_service()->set_interface("URS.Other");
  refused = same->call("camus.registry", "Register", registration.SerializeAsString(), 10s);
  EXPECT_EQ(refused.status, planet::ALREADY_EXISTS);
  EXPECT_EQ(refused.message,
            "service diag is provided by sam with interface URS.Diagnostic; another provider must register the same "
            "interface, not 'URS.Other'");

  EXPECT_EQ(diag_peers(), "sam-a");
  for (int i = 0; i < 10; ++i) ASSERT_TRUE(echo(*viewer_, "still sam-a's").ok());
  EXPECT_EQ(changes(), (std::vector<std::string>{"registered/available/1"}));
}

}  // namespace
}  // namespace urs::camus_server::test
