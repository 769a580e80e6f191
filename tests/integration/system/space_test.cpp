// The CAMUS space end to end on loopback: CLI → server → SAM → diagnostic agent, with faults.

#include <gmock/gmock.h>

#include <regex>
#include <thread>

#include "Diagnostic.pb.h"
#include "space_fixture.hpp"
#include "urs/planet/client.hpp"

namespace urs::test {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;
using namespace std::chrono_literals;

TEST_F(SpaceTest, CallThroughServerAndSamReturnsTheAgentsReply) {
  auto r = urs({"call", "diag", "echo", R"({"text":"hello space"})"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.out, "{\"result\":\"hello space\"}\n");

  r = urs({"call", "diag", "add", R"({"a":1.5,"b":2.25})"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.out, "{\"result\":3.75}\n");
}

TEST_F(SpaceTest, ListShowsTheServiceWithItsInterfaceAndOwner) {
  auto r = urs({"ls"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("diag"));
  EXPECT_THAT(r.out, HasSubstr("URS.Diagnostic"));
  EXPECT_THAT(r.out, HasSubstr("available"));
}

TEST_F(SpaceTest, ErrorsAreTypedAndPrecise) {
  auto r = urs({"call", "nosuch", "echo", "{}"});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("UNKNOWN_SERVICE"));
  EXPECT_THAT(r.err, HasSubstr("nosuch"));

  r = urs({"call", "diag", "explode", "{}"});
  EXPECT_NE(r.exit_code, 0);
  EXPECT_THAT(r.err, HasSubstr("UNKNOWN_OPERATION"));
  EXPECT_THAT(r.err, HasSubstr("explode"));

  r = urs({"call", "diag", "add", R"({"a":"not a number"})"});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("BAD_ARGUMENTS"));

  r = urs({"call", "diag", "fail", R"({"reason":"battery low","code":7})"});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("USER_EXCEPTION URS.Failure"));
  EXPECT_THAT(r.err, HasSubstr("battery low"));
  EXPECT_THAT(r.err, HasSubstr("\"code\":7"));
}

TEST_F(SpaceTest, DeadlineExceededWhileOtherCallsKeepFlowing) {
  std::thread slow([&] {
    auto r = urs({"call", "diag", "sleep", R"({"ms":3000})", "--deadline-ms", "300"});
    EXPECT_EQ(r.exit_code, 1);
    EXPECT_THAT(r.err, HasSubstr("DEADLINE_EXCEEDED"));
  });
  // While the agent sleeps, another call through the same server and SAM is answered.
  auto r = urs({"call", "diag", "echo", R"({"text":"still here"})"});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  slow.join();
}

TEST_F(SpaceTest, ACallWithoutDeadlineGetsTheOneTheServiceAdvertised) {
  // diag registered with deadline_ms 5000 (sam.yaml): a call that gives none is cut there (by the
  // server, or by the agent, which sees the deadline the server forwards), whatever default the
  // client might have had; with 10 s the 5.2 s sleep would answer OK.
  auto r = urs({"call", "diag", "sleep", R"({"ms":5200})"});
  EXPECT_EQ(r.exit_code, 1) << r.out;
  EXPECT_THAT(r.err, HasSubstr("DEADLINE_EXCEEDED"));
  r = urs({"call", "diag", "echo", R"({"text":"x"})", "--deadline-ms", "0"});
  EXPECT_EQ(r.exit_code, 2) << "a deadline of 0 ms is not a deadline: " << r.err;
}

TEST_F(SpaceTest, WrongTokenIsRefusedWithTheReason) {
  write(dir_ + "/bad-token", "wrong\n");
  auto r = run_command(
      {URS_CLI_BIN, "--server", server_address(), "--token-file", dir_ + "/bad-token", "--timeout-ms", "2000", "ls"});
  EXPECT_EQ(r.exit_code, 3);
  EXPECT_THAT(r.err, HasSubstr("wrong token"));
}

TEST_F(SpaceTest, EventsPublishedByAnAgentReachAWatcher) {
  auto watcher_process = watch("lab/#", 1, 10000);
  Process& watcher = *watcher_process;
  // The watch subscription is in place once a probe event reaches it; publish until one does.
  ASSERT_TRUE(wait_until(
      [&] {
        urs({"call", "diag", "notify", R"({"topic":"lab/door","text":"opened"})"});
        return !watcher.running();
      },
      10s));
  EXPECT_EQ(watcher.wait(1s), 0);
  EXPECT_THAT(watcher.log(), HasSubstr("\"topic\":\"lab/door\""));
  EXPECT_THAT(watcher.log(), HasSubstr("\"text\":\"opened\""));
}

TEST_F(SpaceTest, DescribeShowsEachOperationAsIdlDeclaresIt) {
  const auto r = urs({"describe", "diag"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.out,
            "diag implements URS.Diagnostic (IDL:URS/Diagnostic:1.0)\n"
            "  string echo(in string text);\n"
            "  double add(in double a, in double b);\n"
            "  void sleep(in unsigned long ms);\n"
            "  sequence<octet> blob(in unsigned long size);\n"
            "  unsigned long long checksum(in sequence<octet> data);\n"
            "  void fail(in string reason, in long code) raises (URS::Failure);\n"
            "  oneway void notify(in string topic, in string text);\n");
}

TEST_F(SpaceTest, PubSendsTypedEventsAndWatchDecodesEveryTypeTheSpaceKnows) {
  auto watcher_process = watch("lab/#", 0, 30000);  // until stopped: probes may be several
  Process& watcher = *watcher_process;
  // The watch subscription is in place once a probe event reaches it.
  ASSERT_TRUE(wait_until(
      [&] {
        urs({"pub", "lab/probe", R"({"reason":"jammed","code":3})", "--type", "URS.Failure"});
        return watcher.log().find("lab/probe") != std::string::npos;
      },
      10s));
  EXPECT_THAT(watcher.log(), HasSubstr(R"("content_type":"URS.Failure","payload":{"reason":"jammed","code":3})"));

  // A type that only a service registered after the watcher started describes: a TTS agent's.
  write(dir_ + "/tts.yaml", "agents:\n  - name: tts\n    type: tts\n");
  Process tts({URS_SAM_BIN, "--space", "lab", "--server", server_address(), "--config", dir_ + "/tts.yaml",
               "--token-file", dir_ + "/token"},
              dir_ + "/tts.log");
  ASSERT_TRUE(wait_for_service("tts")) << tts.log();
  auto r = urs({"pub", "lab/voice", R"({"name":"en","language":"en-GB"})", "--type", "URC.Voice"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  // Untyped JSON travels as application/json.
  r = urs({"pub", "lab/raw", R"({"on":true})"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(wait_until([&] { return watcher.log().find("lab/raw") != std::string::npos; }, 10s)) << watcher.log();
  EXPECT_THAT(watcher.log(), HasSubstr(R"("content_type":"URC.Voice","payload":{"name":"en","language":"en-GB")"));
  EXPECT_THAT(watcher.log(), HasSubstr(R"("content_type":"application/json","payload":{"on":true})"));
  EXPECT_THAT(watcher.log(), Not(HasSubstr("base64")));

  r = urs({"pub", "lab/x", "{}", "--type", "URC.NoSuchType"});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("the space knows no message type URC.NoSuchType"));
  r = urs({"pub", "lab/x", R"({"code":"many"})", "--type", "URS.Failure"});
  EXPECT_EQ(r.exit_code, 2);
  r = urs({"pub", "lab/*", "{}"});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.err, HasSubstr("BAD_ARGUMENTS"));
}

TEST_F(SpaceTest, TaskPublishStepSendsATypedEvent) {
  auto watcher_process = watch("door/#", 1, 20000);
  Process& watcher = *watcher_process;
  write(dir_ + "/task.yaml",
        "name: announce\n"
        "steps:\n"
        "  - publish: {topic: door/front, type: URS.Failure, payload: {reason: open, code: 1}}\n");
  // Until the watcher's subscription is in place, runs publish into the void; run until one lands.
  ASSERT_TRUE(wait_until(
      [&] {
        auto r = urs({"task", "run", "--file", dir_ + "/task.yaml", "--wait"});
        EXPECT_THAT(r.out, HasSubstr("succeeded")) << r.err;
        return !watcher.running();
      },
      10s));
  EXPECT_THAT(watcher.log(), HasSubstr(R"("content_type":"URS.Failure","payload":{"reason":"open","code":1})"));
  // A task publishes as its owner: here the runner, the credential of --token-file.
  EXPECT_THAT(watcher.log(), HasSubstr(R"("source":"space")"));

  write(dir_ + "/bad.yaml", "name: bad\nsteps:\n  - publish: {topic: door/front, type: URS.Nothing}\n");
  auto r = urs({"task", "run", "--file", dir_ + "/bad.yaml", "--wait"});
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_THAT(r.out, HasSubstr("no registered interface describes the type URS.Nothing"));
  write(dir_ + "/worse.yaml", "name: worse\nsteps:\n  - publish: {topic: \"door/*\"}\n");
  r = urs({"task", "run", "--file", dir_ + "/worse.yaml"});
  EXPECT_NE(r.exit_code, 0);
  EXPECT_THAT(r.err, HasSubstr("steps[0].publish.topic"));
  EXPECT_THAT(r.err, HasSubstr("missing 'type'"));
}

TEST_F(SpaceTest, ContextSetGetAndTaskRun) {
  auto r = urs({"context", "set", "room/light", R"({"on":true,"lux":420})"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  r = urs({"context", "get", "room/light"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("\"lux\":420"));

  write(dir_ + "/task.yaml",
        "name: greet\n"
        "steps:\n"
        "  - call: {service: diag, operation: echo, args: {text: hi}}\n"
        "  - call: {service: diag, operation: add, args: {a: 1, b: 2}}\n");
  r = urs({"task", "run", "--file", dir_ + "/task.yaml", "--wait"});
  EXPECT_EQ(r.exit_code, 0) << r.out << r.err;
  EXPECT_THAT(r.out, HasSubstr("succeeded"));
}

TEST_F(SpaceTest, ServerKilledAndRestartedSamReRegistersWithoutRestart) {
  const pid_t sam_pid = sam_->pid();
  server_->kill9();
  start_server(port_);
  auto restarted = std::chrono::steady_clock::now();
  ASSERT_TRUE(wait_for_service("diag", 2s)) << "diag not listed within 2 s of the restart";
  auto listed_after = std::chrono::steady_clock::now() - restarted;
  RecordProperty("relisted_ms",
                 std::to_string(std::chrono::duration_cast<std::chrono::milliseconds>(listed_after).count()));
  auto r = urs({"call", "diag", "echo", R"({"text":"after restart"})"});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(sam_->running());
  EXPECT_EQ(sam_->pid(), sam_pid);
}

TEST_F(SpaceTest, LargeReplyDoesNotDelayASmallCallOnTheSameConnection) {
  planet::ClientOptions options;
  options.port = static_cast<uint16_t>(port_);
  options.token = "s3cret-token";
  planet::Client client(options);
  client.start();
  ASSERT_TRUE(client.wait_connected(5s));

  // An image-sized reply arrives whole and intact through both chunked hops.
  URS::Diagnostic_blob_Request image;
  image.set_size(921600);
  auto image_result = client.call("diag", "blob", image.SerializeAsString(), 10s);
  ASSERT_TRUE(image_result.ok()) << image_result.message;
  URS::Diagnostic_blob_Reply image_reply;
  ASSERT_TRUE(image_reply.ParseFromString(image_result.payload));
  ASSERT_EQ(image_reply.result().size(), 921600u);
  EXPECT_EQ(static_cast<unsigned char>(image_reply.result()[921599]), 921599 % 251);

  // Ordering: a small call made right after a large one is answered first, on the same
  // connection. The large reply is 16 MiB so that its transfer (hundreds of chunks on each hop)
  // outlasts any scheduling delay of the small call on a loaded machine; with one frame blocking
  // the connection the small reply would have to wait for all of it.
  std::mutex mutex;
  std::condition_variable cv;
  std::vector<std::string> order;
  URS::Diagnostic_blob_Request big;
  big.set_size(16u << 20);
  URS::Diagnostic_echo_Request small;
  small.set_text("tiny");
  planet::CallResult big_result;
  client.call_async("diag", "blob", big.SerializeAsString(), 30s, [&](planet::CallResult r) {
    std::lock_guard<std::mutex> lock(mutex);
    big_result = std::move(r);
    order.push_back("blob");
    cv.notify_all();
  });
  client.call_async("diag", "echo", small.SerializeAsString(), 30s, [&](planet::CallResult r) {
    std::lock_guard<std::mutex> lock(mutex);
    EXPECT_TRUE(r.ok()) << r.message;
    order.push_back("echo");
    cv.notify_all();
  });
  std::unique_lock<std::mutex> lock(mutex);
  ASSERT_TRUE(cv.wait_for(lock, 30s, [&] { return order.size() == 2; }));
  ASSERT_TRUE(big_result.ok()) << big_result.message;
  EXPECT_EQ(order.front(), "echo") << "the small call waited for the 16 MiB reply";
}

TEST_F(SpaceTest, PythonClientCallsAndReceivesAnEventFromTheSpecAlone) {
  // Its calls carry no deadline: diag's own (5000 ms, sam.yaml) bounds a 5200 ms sleep, which
  // would answer OK within 10 s.
  auto r = run_command({"/usr/bin/python3", URS_PY_CLIENT, "--server", server_address(), "--token-file",
                        dir_ + "/token", "--pythonpath", URS_PY_PATH, "--sleep-ms", "5200"},
                       30s);
  EXPECT_EQ(r.exit_code, 0) << r.out << r.err;
  EXPECT_THAT(r.out, HasSubstr("as space role OPERATOR"));  // the --token-file credential
  EXPECT_THAT(r.out, HasSubstr("echo reply: hola"));
  EXPECT_THAT(r.out, HasSubstr("sleep reply: DEADLINE_EXCEEDED"));
  EXPECT_THAT(r.out, HasSubstr("event: lab/python"));
}

// One call followed: the trace id `urs call` prints is on the server's line for the call and on
// the SAM's line for serving it (both log at debug level here).
TEST_F(SpaceTest, OneCallsTraceIdIsOnTheServersAndTheSamsLinesForIt) {
  auto r = urs({"call", "diag", "echo", R"({"text":"followed"})", "--show-trace"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  std::smatch match;
  ASSERT_TRUE(std::regex_search(r.err, match, std::regex("trace ([0-9a-f]{32})\n"))) << r.err;
  const std::string id = match[1];
  const std::regex server_line("trace=" + id + " call diag\\.echo from space: OK in [0-9]+ us");
  const std::regex sam_line("trace=" + id + " served diag\\.echo: OK in [0-9]+ us");
  EXPECT_TRUE(wait_until([&] { return std::regex_search(server_->log(), server_line); }, 5s)) << server_->log();
  EXPECT_TRUE(wait_until([&] { return std::regex_search(sam_->log(), sam_line); }, 5s)) << sam_->log();
  // Another call is another trace.
  r = urs({"call", "diag", "echo", R"({"text":"again"})", "--show-trace"});
  ASSERT_TRUE(std::regex_search(r.err, match, std::regex("trace ([0-9a-f]{32})\n")));
  EXPECT_NE(match[1], id);
  // A caller's trace is taken and carried on; a value that is not one is refused before calling.
  const std::string given = "4bf92f3577b34da6a3ce929d0e0e4736";
  r = urs({"call", "diag", "echo", R"({"text":"given"})", "--traceparent", "00-" + given + "-00f067aa0ba902b7-01",
           "--show-trace"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_THAT(r.err, HasSubstr("trace " + given + "\n"));
  const std::regex given_line("trace=" + given + " served diag\\.echo: OK in [0-9]+ us");
  EXPECT_TRUE(wait_until([&] { return std::regex_search(sam_->log(), given_line); }, 5s)) << sam_->log();
  r = urs({"call", "diag", "echo", "{}", "--traceparent", "00-" + given + "-0000000000000000-01"});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("--traceparent: "));
}

TEST_F(SpaceTest, SamMetricsCountTheCallsItServedAndItsReadiness) {
  const uint16_t port = sam_metrics_port();
  for (int i = 0; i < 2; ++i) ASSERT_EQ(urs({"call", "diag", "echo", R"({"text":"x"})"}).exit_code, 0);
  ASSERT_EQ(urs({"call", "diag", "fail", R"({"reason":"r","code":1})"}).exit_code, 1);
  auto response = http_get(port, "/metrics");
  ASSERT_EQ(response.status, 200);
  const std::string& text = response.body;
  auto served = [&](const std::string& operation, const std::string& status) {
    return metric_value(text, "urslink_served_calls_total",
                        {{"via", "planet"}, {"service", "diag"}, {"operation", operation}, {"status", status}});
  };
  EXPECT_EQ(served("echo", "OK"), 2);
  EXPECT_EQ(served("fail", "USER_EXCEPTION"), 1);
  EXPECT_EQ(metric_value(text, "urslink_build_info", {{"program", "urs-sam"}, {"space", "lab"}}), 1);
  auto checked = promtool_check_metrics(text);
  EXPECT_EQ(checked.out + checked.err, "") << text;
  auto ready = http_get(port, "/readyz");
  EXPECT_EQ(ready.status, 200);
  EXPECT_EQ(ready.body, "ok agents registered\n");
  // Without its server the SAM is alive but not ready.
  server_.reset();
  EXPECT_TRUE(wait_until([&] { return http_get(port, "/readyz").status == 503; }, 10s));
  EXPECT_THAT(http_get(port, "/readyz").body, HasSubstr("not ready agents registered: not connected to"));
  EXPECT_EQ(http_get(port, "/healthz").status, 200);
}

}  // namespace
}  // namespace urs::test
