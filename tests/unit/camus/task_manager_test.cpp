#include "urs/camus_server/task_manager.hpp"

#include <google/protobuf/util/json_util.h>
#include <gtest/gtest.h>

#include <fstream>
#include <map>
#include <sstream>

#include "fakes.hpp"
#include "urs/camus_server/tasks_agent.hpp"
#include "urs/util/cli.hpp"

namespace urs::camus_server::test {
namespace {

namespace gp = google::protobuf;

camus::TaskRunRequest by_name(const std::string& name) {
  camus::TaskRunRequest request;
  request.set_name(name);
  return request;
}

camus::TaskRunRequest inline_yaml(const std::string& yaml) {
  camus::TaskRunRequest request;
  request.set_yaml(yaml);
  return request;
}

// The pieces around a task manager: in-memory bus, registry with test.Navigation, context store.
class TaskTest : public ::testing::Test, protected ServerCore {
 protected:
  void SetUp() override {
    ASSERT_TRUE(registry.register_service(sam, navigation_registration("robot1.navigation")).ok());
  }

  std::unique_ptr<TaskManager> make_manager(const std::string& db_path = "", const std::string& tasks_dir = "") {
    TaskManagerOptions options;
    options.tasks_dir = tasks_dir;
    auto manager = std::make_unique<TaskManager>(db_path, options, invoker, bus, context, registry, sink, clock);
    manager->start();
    return manager;
  }

  void publish(const std::string& topic, const std::string& json) {
    PublishInput in;
    in.topic = topic;
    in.payload = json;
    in.content_type = "application/json";
    in.source = "sam@robot1";
    bus.publish(std::move(in), nullptr);
  }

  // JSON of a recorded call's payload, decoded with the registered interface.
  std::string args_of(const FakeInvoker::Call& call) {
    auto schema = registry.schema_for_service(call.request.service());
    const auto* method = schema->service().FindMethodByName(call.request.operation());
    return schema->payload_to_json(*method->input_type(), call.request.payload()).value();
  }

  // Waits for a published TaskRun of `run_id` with the given state and step.
  bool wait_run(const std::string& run_id, const std::string& state, int step = -1) {
    return sink
        .wait_for([&](const RecordedEvent& e) {
          if (e.type != "urs.camus.TaskRun") return false;
          const auto run = e.as<camus::TaskRun>();
          return run.run_id() == run_id && run.state() == state && (step < 0 || run.step() == uint32_t(step));
        })
        .has_value();
  }

  RecordingSink sink;  // where task progress goes
  FakeInvoker invoker;
  std::shared_ptr<FakeSession> sam = std::make_shared<FakeSession>(1, "sam@robot1", planet::SAM);
};

TEST_F(TaskTest, SquarePathCallsInOrderAndWaitsForEachArrival) {
  // The fake base arrives at once: the arrival is published before wait_event even starts.
  invoker.set_handler([this](const planet::Request& request, std::function<void(planet::CallResult)> done) {
    done(planet::CallResult::success({}));
    if (request.operation() == "moveTo") publish(request.service() + "/arrived", "{\"ok\": true}");
  });
  auto manager = make_manager("", URS_CAMUS_TASKS_DIR);
  auto run = manager->run(by_name("square-path"), "cli");
  ASSERT_TRUE(run.ok()) << run.message();
  EXPECT_EQ(run->state(), "running");
  EXPECT_EQ(run->steps(), 11u);
  EXPECT_EQ(run->trigger(), "cli");
  auto done = manager->wait_finished(run->run_id(), kWait);
  ASSERT_TRUE(done.ok());
  ASSERT_EQ(done->state(), "succeeded") << done->message();
  EXPECT_EQ(done->message(), "completed 11 steps");

  auto calls = invoker.calls();
  ASSERT_EQ(calls.size(), 6u);
  EXPECT_EQ(calls[0].caller, "task:square-path/" + run->run_id());
  EXPECT_EQ(calls[0].request.operation(), "setSpeed");
  EXPECT_EQ(calls[0].request.deadline_ms(), 5000u);
  EXPECT_EQ(args_of(calls[0]), "{\"speed\":500}");
  const char* targets[] = {"{\"x\":1.5,\"y\":1}", "{\"x\":1.5,\"y\":3}", "{\"x\":5,\"y\":3}", "{\"x\":5,\"y\":1}",
                           "{\"x\":1.5,\"y\":1}"};
  for (int i = 0; i < 5; ++i) {
    EXPECT_EQ(calls[i + 1].request.operation(), "moveTo");
    EXPECT_EQ(args_of(calls[i + 1]), targets[i]);
  }
  EXPECT_TRUE(wait_run(run->run_id(), "running", 10));
}

TEST_F(TaskTest, WaitEventMatchesFieldsOfTypedPayloads) {
  auto manager = make_manager();
  auto run = manager->run(inline_yaml(R"(
name: match
steps:
  - wait_event: {pattern: "robot1.navigation/arrived", match: {x: 5, count: 2}, timeout_ms: 5000}
)"),
                          "cli");
  ASSERT_TRUE(run.ok()) << run.message();
  auto arrived = [&](double x, int64_t count) {
    auto schema = registry.schema_with_message("test.Arrived");
    auto payload =
        schema->json_to_payload(*schema->find_message("test.Arrived"),
                                "{\"x\": " + std::to_string(x) + ", \"count\": " + std::to_string(count) + "}");
    PublishInput in;
    in.topic = "robot1.navigation/arrived";
    in.payload = payload.value();
    in.content_type = "test.Arrived";
    bus.publish(std::move(in), nullptr);
  };
  arrived(1.5, 2);  // wrong x
  arrived(5, 1);    // wrong count
  arrived(5, 2);    // int64 count arrives as "2" in JSON: still equal to 2
  auto done = manager->wait_finished(run->run_id(), kWait);
  ASSERT_EQ(done->state(), "succeeded") << done->message();
}

TEST_F(TaskTest, WaitContextSeesCurrentAndLaterValues) {
  auto manager = make_manager();
  auto run = manager->run(inline_yaml(R"(
steps:
  - wait_context: {key: door/open, equals: true, timeout_ms: 5000}
  - wait_context: {key: door/open, exists: false, timeout_ms: 5000}
)"),
                          "cli");
  ASSERT_TRUE(run.ok()) << run.message();
  EXPECT_EQ(run->task(), "inline");
  ASSERT_TRUE(wait_run(run->run_id(), "running", 0));
  camus::ContextSetRequest set;
  set.set_key("door/open");
  set.mutable_value()->set_bool_value(true);
  ASSERT_TRUE(context.set(set, "sam").ok());
  ASSERT_TRUE(wait_run(run->run_id(), "running", 1));
  ASSERT_TRUE(context.remove("door/open", "sam").ok());
  auto done = manager->wait_finished(run->run_id(), kWait);
  ASSERT_EQ(done->state(), "succeeded") << done->message();
}

TEST_F(TaskTest, StepFailuresArePrecise) {
  invoker.set_handler([](const planet::Request& request, std::function<void(planet::CallResult)> done) {
    done(planet::CallResult::error(planet::DEADLINE_EXCEEDED, "no reply from " + request.service() + "." +
                                                                  request.operation() + " within 5000 ms"));
  });
  auto manager = make_manager();
  auto failed = [&](const std::string& yaml) {
    auto run = manager->run(inline_yaml(yaml), "cli");
    EXPECT_TRUE(run.ok()) << run.message();
    auto done = manager->wait_finished(run->run_id(), kWait);
    EXPECT_EQ(done->state(), "failed");
    return done->message();
  };
  EXPECT_EQ(failed("steps: [{sleep: {ms: 0}}, {call: {service: robot1.navigation, operation: moveTo, args: {x: 1}}}]"),
            "steps[1] (call robot1.navigation.moveTo) failed: DEADLINE_EXCEEDED: no reply from "
            "robot1.navigation.moveTo within 5000 ms");
  EXPECT_EQ(failed("steps: [{call: {service: robot1.navigation, operation: fly}}]"),
            "steps[0] (call robot1.navigation.fly) failed: UNKNOWN_OPERATION: interface test.Navigation has no "
            "operation 'fly'");
  EXPECT_EQ(failed("steps: [{call: {service: robot1.navigation, operation: moveTo, args: {z: 1}}}]"),
            "steps[0] (call robot1.navigation.moveTo) failed: BAD_ARGUMENTS: args {\"z\":1} do not fit: JSON for "
            "test.MoveTo: z: Cannot find field.");
  EXPECT_EQ(failed("steps: [{call: {service: robot9.navigation, operation: moveTo, args: {x: 1}}}]"),
            "steps[0] (call robot9.navigation.moveTo) failed: BAD_ARGUMENTS: cannot encode args: service "
            "'robot9.navigation' is not registered, or registered without a descriptor set");
  EXPECT_EQ(failed("repeat: 2\nsteps: [{wait_event: {pattern: never/happens, timeout_ms: 20}}]"),
            "iteration 1/2, steps[0] (wait_event never/happens) failed: DEADLINE_EXCEEDED: no event on "
            "'never/happens' within 20 ms");
  EXPECT_EQ(
      failed("steps: [{wait_context: {key: k, exists: true, timeout_ms: 20}}]"),
      "steps[0] (wait_context k) failed: DEADLINE_EXCEEDED: context entry 'k' did not come to exist within 20 ms");
}

TEST_F(TaskTest, CancelStopsAWaitingRunAtOnce) {
  auto manager = make_manager();
  auto run = manager->run(inline_yaml("name: waits\nsteps: [{wait_event: {pattern: never/happens}}]"), "cli");
  ASSERT_TRUE(run.ok());
  ASSERT_TRUE(wait_run(run->run_id(), "running", 0));
  auto cancelled = manager->cancel(run->run_id(), "cli@host");
  ASSERT_TRUE(cancelled.ok());
  EXPECT_EQ(cancelled->state(), "cancelled");
  EXPECT_EQ(cancelled->message(), "cancelled by cli@host at steps[0] (wait_event never/happens)");
  EXPECT_NE(cancelled->finished_unix_ns(), 0);
  EXPECT_TRUE(wait_run(run->run_id(), "cancelled"));
  // Cancelling again is harmless; unknown runs are named.
  EXPECT_EQ(manager->cancel(run->run_id(), "x")->state(), "cancelled");
  EXPECT_EQ(manager->cancel("r999", "x").message(), "no task run 'r999'");
  manager->stop();  // joins the run thread: it has noticed the cancellation
}

TEST_F(TaskTest, CancelDuringACallDoesNotWaitForTheReply) {
  std::function<void(planet::CallResult)> held;
  std::mutex held_mutex;
  invoker.set_handler([&](const planet::Request&, std::function<void(planet::CallResult)> done) {
    std::lock_guard<std::mutex> lock(held_mutex);
    held = std::move(done);  // the provider never answers (for now)
  });
  auto manager = make_manager();
  auto run = manager->run(inline_yaml("steps: [{call: {service: robot1.navigation, operation: getPosition}}]"), "cli");
  ASSERT_TRUE(invoker.wait_calls(1));
  EXPECT_EQ(manager->cancel(run->run_id(), "op")->state(), "cancelled");
  manager->stop();
  std::lock_guard<std::mutex> lock(held_mutex);
  held(planet::CallResult::success({}));  // late answer: ignored
  camus::TaskStatusRequest status;
  status.set_run_id(run->run_id());
  EXPECT_EQ(manager->status(status)->state(), "cancelled");
}

TEST_F(TaskTest, DefineRunStatusAndList) {
  auto manager = make_manager();
  EXPECT_EQ(manager->define("Bad Name", "steps: [{sleep: {ms: 1}}]").message(),
            "task name 'Bad Name' is not valid: character ' ' is not allowed (use letters, digits and . _ -)");
  EXPECT_EQ(manager->define("a", "name: b\nsteps: [{sleep: {ms: 1}}]").message(),
            "task name 'a' does not match the name 'b' in its YAML");
  ASSERT_TRUE(manager->define("nap", "steps: [{sleep: {ms: 1}}]").ok());
  EXPECT_EQ(manager->run(by_name("nope"), "cli").message(), "no task named 'nope' (define it first, or pass its yaml)");
  camus::TaskRunRequest both;
  both.set_name("nap");
  both.set_yaml("steps: []");
  EXPECT_EQ(manager->run(both, "cli").message(), "Run takes a task name or an inline yaml, not both");
  EXPECT_EQ(manager->run(camus::TaskRunRequest(), "cli").message(), "Run needs a task name or an inline yaml");

  camus::TaskStatusRequest by_task;
  by_task.set_name("nap");
  EXPECT_EQ(manager->status(by_task).message(), "task 'nap' has not run yet");
  auto first = manager->run(by_name("nap"), "cli");
  auto second = manager->run(by_name("nap"), "cli");
  ASSERT_TRUE(manager->wait_finished(second->run_id(), kWait).ok());
  ASSERT_TRUE(manager->wait_finished(first->run_id(), kWait).ok());
  EXPECT_EQ(manager->status(by_task)->run_id(), second->run_id());
  camus::TaskStatusRequest unknown;
  unknown.set_name("ghost");
  EXPECT_EQ(manager->status(unknown).message(), "no task named 'ghost'");
  EXPECT_EQ(manager->status(camus::TaskStatusRequest()).message(), "Status needs a run_id or a task name");
  camus::TaskStatusRequest either;  // a CLI that cannot tell a run id from a task name sends both
  either.set_run_id("nap");
  either.set_name("nap");
  EXPECT_EQ(manager->status(either)->run_id(), second->run_id());
  either.set_run_id(first->run_id());
  either.set_name(first->run_id());
  EXPECT_EQ(manager->status(either)->run_id(), first->run_id());
  either.set_run_id("zzz");
  either.set_name("zzz");
  EXPECT_EQ(manager->status(either).message(), "no task run or task named 'zzz'");

  auto list = manager->list();
  ASSERT_EQ(list.tasks_size(), 1);
  EXPECT_EQ(list.tasks(0).name(), "nap");
  ASSERT_EQ(list.runs_size(), 2);
  EXPECT_EQ(list.runs(0).run_id(), second->run_id());  // newest first
}

TEST_F(TaskTest, TriggerStartsARunPerMatchingEvent) {
  auto manager = make_manager();
  ASSERT_TRUE(
      manager
          ->define(
              "greet",
              "trigger: {event: \"doorbell/#\"}\nsteps: [{call: {service: robot1.navigation, operation: getPosition}}]")
          .ok());
  publish("doorbell/front", "{}");
  ASSERT_TRUE(invoker.wait_calls(1));
  camus::TaskStatusRequest by_task;
  by_task.set_name("greet");
  auto run = manager->status(by_task);
  ASSERT_TRUE(run.ok());
  EXPECT_EQ(run->trigger(), "event:doorbell/front");
  ASSERT_EQ(manager->wait_finished(run->run_id(), kWait)->state(), "succeeded");
  publish("doorbell/back", "{}");
  ASSERT_TRUE(invoker.wait_calls(2));
  publish("elsewhere", "{}");
  bus.flush();
  EXPECT_EQ(invoker.calls().size(), 2u);
}

TEST_F(TaskTest, StateSurvivesRestartAndRunningRunsResumeAtTheirStep) {
  TempDir dir;
  const std::string db = dir.file("tasks.db");
  const std::string yaml = R"(
name: errand
steps:
  - call: {service: robot1.navigation, operation: moveTo, args: {x: 1, y: 2}}
  - wait_event: {pattern: errand/go}
  - call: {service: robot1.navigation, operation: moveTo, args: {x: 3, y: 4}}
)";
  std::string run_id;
  std::string finished_id;
  {
    auto manager = make_manager(db);
    ASSERT_TRUE(manager->define("errand", yaml).ok());
    auto quick = manager->run(inline_yaml("name: quick\nsteps: [{sleep: {ms: 0}}]"), "cli");
    finished_id = quick->run_id();
    ASSERT_EQ(manager->wait_finished(finished_id, kWait)->state(), "succeeded");
    auto run = manager->run(by_name("errand"), "cli");
    ASSERT_TRUE(run.ok());
    run_id = run->run_id();
    ASSERT_TRUE(wait_run(run_id, "running", 1));  // waiting for errand/go
    // The server goes away here (stop() leaves the stored state exactly as a crash would).
  }
  ASSERT_EQ(invoker.calls().size(), 1u);

  auto manager = make_manager(db);
  camus::TaskStatusRequest status;
  status.set_run_id(run_id);
  auto resumed = manager->status(status);
  ASSERT_TRUE(resumed.ok()) << resumed.message();
  EXPECT_EQ(resumed->state(), "running");
  EXPECT_EQ(resumed->step(), 1u);
  EXPECT_EQ(resumed->task(), "errand");
  status.set_run_id(finished_id);
  EXPECT_EQ(manager->status(status)->state(), "succeeded");
  EXPECT_TRUE(sink.wait_for([&](const RecordedEvent& e) {
    const auto r = e.as<camus::TaskRun>();
    return r.run_id() == run_id && r.message() == "resumed after a server restart at steps[1] (wait_event errand/go)";
  }));

  publish("errand/go", "{}");
  auto done = manager->wait_finished(run_id, kWait);
  ASSERT_EQ(done->state(), "succeeded") << done->message();
  auto calls = invoker.calls();
  ASSERT_EQ(calls.size(), 2u);
  EXPECT_EQ(args_of(calls[1]), "{\"x\":3,\"y\":4}");
  // Numbering continues after the stored runs.
  auto next = manager->run(by_name("errand"), "cli");
  EXPECT_EQ(next->run_id(), "r3");
  manager->cancel(next->run_id(), "test");
}

TEST_F(TaskTest, BadTaskFileStopsStartWithItsName) {
  TempDir dir;
  { std::ofstream(dir.file("broken.yaml")) << "steps:\n  - call: {service: s}\n"; }
  TaskManagerOptions options;
  options.tasks_dir = dir.file("");
  TaskManager manager("", options, invoker, bus, context, registry, sink, clock);
  try {
    manager.start();
    FAIL() << "start() accepted a broken task file";
  } catch (const util::ConfigError& e) {
    EXPECT_EQ(std::string(e.what()), "--tasks-dir: '" + dir.file("broken.yaml") +
                                         "': task 'broken': steps[0].call (line 2): missing 'operation'");
  }
}

TEST_F(TaskTest, AgentServesTheTasksInterface) {
  auto manager = make_manager();
  TasksAgent agent(*manager);
  const auto& iface = agent.interface();
  EXPECT_EQ(iface.full_name(), "urs.camus.Tasks");
  agent::CallContext ctx;
  ctx.caller.name = "cli@host";
  camus::TaskDefinition def;
  def.set_name("nap");
  def.set_yaml("steps: [{sleep: {ms: 0}}]");
  camus::TaskDefineReply defined;
  ASSERT_EQ(agent.invoke(*iface.FindMethodByName("Define"), def, defined, ctx).status, call::Status::OK);
  EXPECT_EQ(defined.task().name(), "nap");
  camus::TaskRun run;
  ASSERT_EQ(agent.invoke(*iface.FindMethodByName("Run"), by_name("nap"), run, ctx).status, call::Status::OK);
  EXPECT_EQ(run.trigger(), "call:cli@host");
  camus::TaskStatusRequest missing;
  missing.set_run_id("r77");
  auto outcome = agent.invoke(*iface.FindMethodByName("Status"), missing, run, ctx);
  EXPECT_EQ(outcome.status, call::Status::NOT_FOUND);
  EXPECT_EQ(outcome.message, "no task run 'r77'");
}

// A task's publish step speaks as the task's owner (who defined it, or ran it inline), under the
// topic rules of any peer: never as the server, never on the server's topics.
TEST_F(TaskTest, PublishStepsPublishAsTheOwnerUnderPeerRules) {
  auto manager = make_manager();
  EventCollector seen;
  bus.subscribe(
      99,
      [] {
        planet::Subscribe s;
        s.set_subscription_id(1);
        s.set_pattern("kr/#");
        return s;
      }(),
      seen.deliver(), seen.ack());
  ASSERT_TRUE(seen.wait_ack());
  const std::string forged = R"(
steps:
  - publish: {topic: registry/diag, type: urs.camus.ServiceInfo, payload: {name: diag, state: gone}}
)";
  auto defined = manager->define("forge", "name: forge" + forged, "ops");
  EXPECT_EQ(defined.status(), planet::BAD_ARGUMENTS);
  EXPECT_NE(defined.message().find("topics under 'registry/' are published by the server alone"), std::string::npos)
      << defined.message();
  EXPECT_EQ(manager->run(inline_yaml(forged), "cli", "ops").status(), planet::BAD_ARGUMENTS);

  ASSERT_TRUE(manager
                  ->define("door", R"(
name: door
steps:
  - publish: {topic: kr/door, type: test.Arrived, payload: {x: 1, count: 2}}
)",
                           "ops")
                  .ok());
  auto run = manager->run(by_name("door"), "cli", "someone-else");
  ASSERT_TRUE(run.ok()) << run.message();
  ASSERT_EQ(manager->wait_finished(run->run_id(), kWait)->state(), "succeeded");
  auto inline_run = manager->run(
      inline_yaml("steps:\n  - publish: {topic: kr/window, type: test.Arrived, payload: {x: 2, count: 1}}\n"), "cli",
      "ops2");
  ASSERT_TRUE(inline_run.ok()) << inline_run.message();
  ASSERT_EQ(manager->wait_finished(inline_run->run_id(), kWait)->state(), "succeeded");
  ASSERT_TRUE(seen.wait_events(2));
  std::map<std::string, std::string> sources;
  for (const auto& event : seen.events()) sources[event.topic()] = event.source();
  EXPECT_EQ(sources["kr/door"], "ops");  // the definer's, whoever ran it
  EXPECT_EQ(sources["kr/window"], "ops2");
}

}  // namespace
}  // namespace urs::camus_server::test
