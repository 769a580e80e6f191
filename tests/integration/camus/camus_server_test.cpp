// urs-camus-server as a real process: Planet clients and SAMs talk to it over TCP on loopback.

#include <gmock/gmock.h>
#include <google/protobuf/descriptor.pb.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <unistd.h>

#include <condition_variable>
#include <filesystem>
#include <fstream>
#include <future>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "camus.pb.h"
#include "process.hpp"
#include "raw_peer.hpp"
#include "urs/planet/client.hpp"

namespace urs::camus_server::test {
namespace {

using namespace std::chrono_literals;
using urs::test::Process;

// Descriptor set of camus.proto (with struct.proto), for a SAM that provides urs.camus.Context.
std::string context_descriptor_set() {
  google::protobuf::FileDescriptorSet set;
  google::protobuf::Struct::descriptor()->file()->CopyTo(set.add_file());
  camus::ContextEntry::descriptor()->file()->CopyTo(set.add_file());
  return set.SerializeAsString();
}

class CamusServerTest : public ::testing::Test {
 protected:
  void SetUp() override { dir_ = urs::test::make_temp_dir("camus"); }

  void TearDown() override {
    if (server_) {
      // In sanitizer builds the server reports races and memory errors on stderr.
      const std::string log = server_->log();
      EXPECT_EQ(log.find("Sanitizer"), std::string::npos) << log;
    }
    if (HasFailure() && server_) std::cerr << "---- server log\n" << server_->log();
    clients_.clear();
    server_.reset();
    std::filesystem::remove_all(dir_);
  }

  std::vector<std::string> server_argv(const std::vector<std::string>& extra = {}) {
    std::vector<std::string> argv{URS_CAMUS_SERVER_BIN,
                                  "--space",
                                  "kr",
                                  "--listen",
                                  "127.0.0.1:0",
                                  "--port-file",
                                  dir_ + "/port",
                                  "--data-dir",
                                  dir_ + "/data",
                                  "--heartbeat-ms",
                                  "200",
                                  "--heartbeat-timeout-ms",
                                  "1000",
                                  "--log-level",
                                  "debug"};
    argv.insert(argv.end(), extra.begin(), extra.end());
    return argv;
  }

  void start_server(const std::vector<std::string>& extra = {}) {
    std::filesystem::remove(dir_ + "/port");
    server_ = std::make_unique<Process>(server_argv(extra), dir_ + "/server.log");
    ASSERT_TRUE(urs::test::wait_until([&] { return std::filesystem::exists(dir_ + "/port"); }, 10s)) << server_->log();
    port_ = static_cast<uint16_t>(std::stoi(urs::test::read_text(dir_ + "/port")));
  }

  planet::Client& connect(const std::string& name, planet::Role role = planet::CLIENT,
                          planet::RequestHandler handler = {}) {
    planet::ClientOptions options;
    options.port = port_;
    options.peer_name = name;
    options.role = role;
    auto client = std::make_unique<planet::Client>(options);
    if (handler) client->set_request_handler(std::move(handler));
    client->start();
    EXPECT_TRUE(client->wait_connected(5s)) << client->last_error();
    clients_.push_back(std::move(client));
    return *clients_.back();
  }

  static planet::CallResult set_context(planet::Client& client, const std::string& key, double value) {
    camus::ContextSetRequest set;
    set.set_key(key);
    set.mutable_value()->set_number_value(value);
    return client.call("camus.context", "Set", set.SerializeAsString(), 5s);
  }

  static planet::CallResult task_call(planet::Client& client, const std::string& op,
                                      const google::protobuf::Message& m) {
    return client.call("camus.tasks", op, m.SerializeAsString(), 5s);
  }

  static camus::TaskRun task_status(planet::Client& client, const std::string& run_id) {
    camus::TaskStatusRequest request;
    request.set_run_id(run_id);
    auto result = task_call(client, "Status", request);
    EXPECT_TRUE(result.ok()) << result.message;
    camus::TaskRun run;
    run.ParseFromString(result.payload);
    return run;
  }

  std::string dir_;
  uint16_t port_ = 0;
  std::unique_ptr<Process> server_;
  std::vector<std::unique_ptr<planet::Client>> clients_;
};

TEST_F(CamusServerTest, ContextSetAndGetOverPlanet) {
  start_server();
  auto& client = connect("cli@test");
  auto set = set_context(client, "robot1/battery", 0.75);
  ASSERT_TRUE(set.ok()) << set.message;
  camus::ContextGetRequest get;
  get.set_key("robot1/battery");
  auto got = client.call("camus.context", "Get", get.SerializeAsString(), 5s);
  ASSERT_TRUE(got.ok()) << got.message;
  camus::ContextEntry entry;
  ASSERT_TRUE(entry.ParseFromString(got.payload));
  EXPECT_DOUBLE_EQ(entry.value().number_value(), 0.75);
  EXPECT_EQ(entry.source(), "anonymous");  // an open server: nothing was authenticated
  EXPECT_TRUE(entry.origin().empty());
  EXPECT_EQ(entry.version(), 1u);

  get.set_key("robot1/nothing");
  got = client.call("camus.context", "Get", get.SerializeAsString(), 5s);
  EXPECT_EQ(got.status, planet::NOT_FOUND);
  EXPECT_EQ(got.message, "no context entry 'robot1/nothing'");
  got = client.call("robot9.navigation", "moveTo", "", 5s);
  EXPECT_EQ(got.status, planet::UNKNOWN_SERVICE);
  EXPECT_EQ(got.message, "no service named 'robot9.navigation' in space kr");
}

TEST_F(CamusServerTest, RoutesToASamWithDeadlinesAndProviderGone) {
  start_server();
  std::mutex mutex;
  std::vector<planet::Responder> held;  // requests the SAM never answers
  auto& sam = connect("sam@robot1", planet::SAM, [&](const planet::Request& request, planet::Responder responder) {
    if (request.operation() == "Get") {
      camus::ContextEntry entry;
      entry.set_key("answered by the SAM");
      responder.reply(planet::CallResult::success(entry.SerializeAsString()));
      return;
    }
    std::lock_guard<std::mutex> lock(mutex);
    held.push_back(std::move(responder));
  });
  camus::RegisterRequest registration;
  registration.mutable_service()->set_name("robot1.kv");
  registration.mutable_service()->set_interface("urs.camus.Context");
  registration.set_descriptor_set(context_descriptor_set());
  std::promise<planet::CallResult> registered;
  sam.register_service(registration, [&](planet::CallResult r) { registered.set_value(std::move(r)); });
  auto outcome = registered.get_future();
  ASSERT_EQ(outcome.wait_for(5s), std::future_status::ready);
  ASSERT_TRUE(outcome.get().ok());

  auto& client = connect("cli@test");
  auto got = client.call("robot1.kv", "Get", camus::ContextGetRequest().SerializeAsString(), 5s);
  ASSERT_TRUE(got.ok()) << got.message;
  camus::ContextEntry entry;
  entry.ParseFromString(got.payload);
  EXPECT_EQ(entry.key(), "answered by the SAM");

  auto wrong = client.call("robot1.kv", "Explode", "", 5s);
  EXPECT_EQ(wrong.status, planet::UNKNOWN_OPERATION);
  EXPECT_EQ(wrong.message, "interface urs.camus.Context has no operation 'Explode'");

  auto late = client.call("robot1.kv", "List", "", 300ms);
  EXPECT_EQ(late.status, planet::DEADLINE_EXCEEDED);
  // The client passes the time left (~300 ms) on; whichever side gives up first says the same.
  EXPECT_THAT(late.message, ::testing::MatchesRegex("no reply from robot1\\.kv\\.List within 2[0-9][0-9] ms|"
                                                    "no reply from robot1\\.kv\\.List within 300 ms"));

  std::promise<planet::CallResult> pending;
  client.call_async("robot1.kv", "Set", "", 10s, [&](planet::CallResult r) { pending.set_value(std::move(r)); });
  ASSERT_TRUE(urs::test::wait_until(
      [&] {
        std::lock_guard<std::mutex> lock(mutex);
        return held.size() == 2;
      },
      5s));
  sam.stop();  // the provider goes away with a call in progress
  auto gone = pending.get_future();
  ASSERT_EQ(gone.wait_for(5s), std::future_status::ready);
  auto result = gone.get();
  EXPECT_EQ(result.status, planet::PROVIDER_GONE);
  EXPECT_EQ(result.message, "provider anonymous of robot1.kv disconnected");
  got = client.call("robot1.kv", "Get", "", 5s);
  EXPECT_EQ(got.status, planet::UNKNOWN_SERVICE);
}

TEST_F(CamusServerTest, Kill9AndRestartKeepsContextAndTasks) {
  start_server();
  std::string waiting_run;
  std::string finished_run;
  {
    auto& client = connect("cli@test");
    ASSERT_TRUE(set_context(client, "room/light", 420).ok());
    ASSERT_TRUE(set_context(client, "room/light", 430).ok());
    camus::TaskDefinition def;
    def.set_name("errand");
    def.set_yaml("steps:\n  - sleep: {ms: 1}\n  - wait_event: {pattern: errand/go}\n");
    ASSERT_TRUE(task_call(client, "Define", def).ok());
    camus::TaskRunRequest quick;
    quick.set_yaml("name: quick\nsteps: [{sleep: {ms: 0}}]");
    auto run = task_call(client, "Run", quick);
    ASSERT_TRUE(run.ok()) << run.message;
    camus::TaskRun parsed;
    parsed.ParseFromString(run.payload);
    finished_run = parsed.run_id();
    ASSERT_TRUE(urs::test::wait_until([&] { return task_status(client, finished_run).state() == "succeeded"; }, 5s));
    camus::TaskRunRequest errand;
    errand.set_name("errand");
    run = task_call(client, "Run", errand);
    ASSERT_TRUE(run.ok()) << run.message;
    parsed.ParseFromString(run.payload);
    waiting_run = parsed.run_id();
    ASSERT_TRUE(urs::test::wait_until([&] { return task_status(client, waiting_run).step() == 1; }, 5s));
  }
  clients_.clear();
  server_->kill9();

  start_server();
  auto& client = connect("cli@test");
  camus::ContextGetRequest get;
  get.set_key("room/light");
  auto got = client.call("camus.context", "Get", get.SerializeAsString(), 5s);
  ASSERT_TRUE(got.ok()) << got.message;
  camus::ContextEntry entry;
  entry.ParseFromString(got.payload);
  EXPECT_DOUBLE_EQ(entry.value().number_value(), 430);
  EXPECT_EQ(entry.version(), 2u);

  EXPECT_EQ(task_status(client, finished_run).state(), "succeeded");
  auto resumed = task_status(client, waiting_run);
  EXPECT_EQ(resumed.state(), "running");
  EXPECT_EQ(resumed.step(), 1u);
  auto list = task_call(client, "List", camus::TaskListRequest());
  camus::TaskListReply tasks;
  tasks.ParseFromString(list.payload);
  ASSERT_EQ(tasks.tasks_size(), 1);
  EXPECT_EQ(tasks.tasks(0).name(), "errand");

  // The resumed run still waits for its event, and finishes once it comes.
  ASSERT_TRUE(client.publish("errand/go", "{}", "application/json").ok());
  EXPECT_TRUE(urs::test::wait_until([&] { return task_status(client, waiting_run).state() == "succeeded"; }, 5s));
}

TEST_F(CamusServerTest, GarbageOnOneConnectionDoesNotDisturbOthers) {
  start_server();
  auto& client = connect("cli@test");
  ASSERT_TRUE(set_context(client, "k", 1).ok());
  urs::test::RawPeer garbage(port_);
  std::string bytes(4, '\xff');  // a length prefix far over any limit
  for (int i = 0; i < 4096; ++i) bytes.push_back(static_cast<char>(i * 37));
  garbage.send_bytes(bytes);
  urs::test::RawPeer half(port_);
  half.send_bytes(std::string("\x00\x00\x00\x10garbage", 11));  // a truncated frame, then silence
  for (int i = 0; i < 20; ++i) ASSERT_TRUE(set_context(client, "k", i).ok());
  EXPECT_TRUE(garbage.closed_by_server(5s));
  EXPECT_TRUE(server_->running());
  EXPECT_TRUE(set_context(client, "k", 99).ok());
}

TEST_F(CamusServerTest, SigtermStopsInOrder) {
  start_server();
  connect("cli@test");
  server_->signal(SIGTERM);
  EXPECT_EQ(server_->wait(10s), 0);
  EXPECT_NE(server_->log().find("stopped"), std::string::npos) << server_->log();
}

TEST_F(CamusServerTest, BadFlagsExitTwoWithOneLine) {
  auto r = urs::test::run_command(
      {URS_CAMUS_SERVER_BIN, "--space", "kr", "--listen", "127.0.0.1:0", "--heartbeat-ms", "abc"});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_EQ(r.err, "urs-camus-server: --heartbeat-ms: 'abc' is not a number of milliseconds (10..3600000)\n");
  r = urs::test::run_command({URS_CAMUS_SERVER_BIN, "--space", "kr", "--listen", "localhost"});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_EQ(r.err, "urs-camus-server: --listen: 'localhost' is not HOST:PORT\n");

  std::filesystem::create_directories(dir_ + "/tasks");
  std::ofstream(dir_ + "/tasks/bad.yaml") << "steps: [{sleep: {}}]\n";
  r = urs::test::run_command(server_argv({"--tasks-dir", dir_ + "/tasks"}));
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_EQ(r.err, "urs-camus-server: --tasks-dir: '" + dir_ +
                       "/tasks/bad.yaml': task 'bad': steps[0].sleep (line 1): missing 'ms'\n");
}

}  // namespace
}  // namespace urs::camus_server::test
