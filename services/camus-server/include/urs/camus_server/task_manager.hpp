#pragma once
// The task manager: defines declarative tasks (TaskSpec), runs them, persists their progress.
//
//  - Every run executes on its own thread. Waits (calls, events, context, sleep) block on the
//    run's condition variable, so Cancel takes effect at once, whatever the step.
//  - A run's state (definition snapshot, state, current step, iteration, event watermark) is
//    written to SQLite before each change is published on "task/<task>/<run_id>" (TaskRun).
//  - After a crash or a stop, runs found "running" resume at their current step: a `call` step is
//    issued again (at-least-once), waits and sleeps start over with their full timeout.
//  - wait_event considers events published after the start of the latest `call` step of the
//    iteration (or the iteration's start, or the previously matched event), so an arrival that
//    happens before the wait begins is not missed.
//  - A task with a trigger starts one run per matching event, unless a run of it is in progress.
//
// Threading: thread-safe. define/run/cancel wait for the disk; call them off the I/O thread.

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "camus.pb.h"
#include "urs/agent/agent.hpp"
#include "urs/camus_server/clock.hpp"
#include "urs/camus_server/context_store.hpp"
#include "urs/camus_server/event_bus.hpp"
#include "urs/camus_server/registry.hpp"
#include "urs/camus_server/sqlite.hpp"
#include "urs/camus_server/task_spec.hpp"
#include "urs/planet/status.hpp"

namespace urs::camus_server {

// How task runs call services (the router in the server; a fake in tests).
class Invoker {
 public:
  virtual ~Invoker() = default;
  // Never blocks; `done` runs exactly once, on any thread, possibly before call() returns.
  virtual void call(const std::string& caller, planet::Request request,
                    std::function<void(planet::CallResult)> done) = 0;
};

struct TaskManagerOptions {
  std::string tasks_dir;        // *.yaml / *.yml defined at start(); empty = none
  size_t max_running = 64;      // runs in progress at once
  size_t keep_finished = 1000;  // finished runs kept (in memory and in the store)
};

class TaskManager {
 public:
  // Opens or creates `db_path` ("" = in memory). Throws SqliteError. Every reference must outlive
  // the manager.
  TaskManager(const std::string& db_path, TaskManagerOptions options, Invoker& invoker, EventSource& events,
              const ContextReader& context, const SchemaLookup& schemas, agent::EventSink& sink, const Clock& clock);
  ~TaskManager();  // stop()
  TaskManager(const TaskManager&) = delete;
  TaskManager& operator=(const TaskManager&) = delete;

  // Loads stored definitions, then --tasks-dir files (which replace stored ones of the same
  // name), arms triggers and resumes interrupted runs. Throws util::ConfigError naming a bad
  // task file.
  void start();
  // Interrupts every run (they stay "running" in the store and resume at the next start()),
  // disarms triggers, joins the run threads. Idempotent.
  void stop();

  Result<camus::TaskDefinition> define(const std::string& name, const std::string& yaml);
  // `trigger` records why the run started ("cli", "event:<topic>", ...).
  Result<camus::TaskRun> run(const camus::TaskRunRequest& request, const std::string& trigger);
  // By run id; else (or when no run has that id) the latest run of the task `name`.
  Result<camus::TaskRun> status(const camus::TaskStatusRequest& request) const;
  Result<camus::TaskRun> cancel(const std::string& run_id, const std::string& by);
  // Definitions by name, runs in progress and the latest 100 finished runs, newest first.
  camus::TaskListReply list() const;
  // Blocks until the run is no longer "running" or `timeout` passes; returns its state.
  Result<camus::TaskRun> wait_finished(const std::string& run_id, std::chrono::milliseconds timeout) const;

 private:
  struct Run;
  struct TriggerGuard;
  enum class StepEnd { Next, Failed, Stopped };

  Result<std::shared_ptr<Run>> start_run_locked(TaskSpec spec, const std::string& yaml, const std::string& trigger);
  void launch(const std::shared_ptr<Run>& run);
  void execute(const std::shared_ptr<Run>& run);
  StepEnd run_step(const std::shared_ptr<Run>& run, const TaskStep& step, std::string& failure);
  StepEnd run_call(const std::shared_ptr<Run>& run, const CallStep& step, std::string& failure);
  StepEnd run_wait_event(const std::shared_ptr<Run>& run, const WaitEventStep& step, std::string& failure);
  StepEnd run_wait_context(const std::shared_ptr<Run>& run, const WaitContextStep& step, std::string& failure);
  StepEnd run_sleep(const std::shared_ptr<Run>& run, const SleepStep& step);
  StepEnd run_publish(const std::shared_ptr<Run>& run, const PublishStep& step, std::string& failure);
  void finish(const std::shared_ptr<Run>& run, const std::string& state, const std::string& message);
  void save_locked(const Run& run);  // run mutex held; takes the db mutex; logs failures
  void publish(const camus::TaskRun& snapshot);
  void arm_trigger_locked(const TaskSpec& spec);
  void on_trigger(const std::string& task, const planet::Event& event);
  void reap_locked();
  std::shared_ptr<Run> find_locked(const std::string& run_id) const;
  Result<Done> define_locked(const TaskSpec& spec, const std::string& yaml);

  const TaskManagerOptions options_;
  Invoker& invoker_;
  EventSource& events_;
  const ContextReader& context_;
  const SchemaLookup& schemas_;
  agent::EventSink& sink_;
  const Clock& clock_;

  mutable std::mutex db_mutex_;  // leaf lock
  Database db_;

  mutable std::mutex mutex_;
  struct Definition {
    std::string yaml;
    TaskSpec spec;
  };
  std::map<std::string, Definition> definitions_;
  std::map<uint64_t, std::shared_ptr<Run>> runs_;  // by run number
  std::map<std::string, uint64_t> triggers_;        // task -> internal subscription
  std::shared_ptr<TriggerGuard> trigger_guard_;
  uint64_t next_run_ = 1;
  bool started_ = false;
  bool stopping_ = false;

  mutable std::mutex finished_mutex_;
  mutable std::condition_variable finished_cv_;
};

// The built-in service "camus.tasks" (urs.camus.Tasks) for the service container.
class TasksAgent final : public agent::ServiceAgent {
 public:
  static constexpr const char* kName = "camus.tasks";
  explicit TasksAgent(TaskManager& manager) : manager_(manager) {}
  const google::protobuf::ServiceDescriptor& interface() const override;
  agent::Outcome invoke(const google::protobuf::MethodDescriptor& method, const google::protobuf::Message& request,
                        google::protobuf::Message& reply, const agent::CallContext& ctx) override;

 private:
  TaskManager& manager_;
};

// True if every (dotted path, value) of `match` is found in the event payload (decoded through
// its content type: "application/json" or a message type known to `schemas`).
bool event_matches(const planet::Event& event,
                   const std::vector<std::pair<std::string, google::protobuf::Value>>& match,
                   const SchemaLookup& schemas);

// Equality of two values; a number also equals a text holding the same number (int64 fields
// appear as text in JSON).
bool values_equal(const google::protobuf::Value& a, const google::protobuf::Value& b);

}  // namespace urs::camus_server
