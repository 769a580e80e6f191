#pragma once
// The task manager: defines declarative tasks (TaskSpec), runs them, persists their progress.
// It keeps the definitions and the table of runs; its components (src/) are the store (SQLite),
// the step runner (what each step does, its waits), the run driver (a run's thread) and the
// triggers (event subscriptions that start runs).
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
//  - A task has an owner: the credential that defined it (or ran it inline), "tasks-dir/<file>"
//    for a --tasks-dir file (a name no credential can have). Its `publish` steps publish as the
//    owner under a peer's topic rules: never on the server's topics (refused when defined).
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

namespace tasks {  // the task manager's components (src/task_*.hpp)
struct Run;
class TaskStore;
class StepRunner;
class RunDriver;
class TaskTriggers;
}  // namespace tasks

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

  // `owner`: the defining credential (empty: "task:<name>" when it publishes).
  Result<camus::TaskDefinition> define(const std::string& name, const std::string& yaml, const std::string& owner = "");
  // `trigger` records why the run started ("cli", "event:<topic>", ...); `caller` owns an inline
  // run (a named task's run is its definition's owner's).
  Result<camus::TaskRun> run(const camus::TaskRunRequest& request, const std::string& trigger,
                             const std::string& caller = "");
  // By run id; else (or when no run has that id) the latest run of the task `name`.
  Result<camus::TaskRun> status(const camus::TaskStatusRequest& request) const;
  Result<camus::TaskRun> cancel(const std::string& run_id, const std::string& by);
  // Definitions by name, runs in progress and the latest 100 finished runs, newest first.
  camus::TaskListReply list() const;
  // Blocks until the run is no longer "running" or `timeout` passes; returns its state.
  Result<camus::TaskRun> wait_finished(const std::string& run_id, std::chrono::milliseconds timeout) const;

 private:
  struct Definition {
    std::string yaml;
    TaskSpec spec;
    std::string owner;
  };

  Result<std::shared_ptr<tasks::Run>> start_run_locked(TaskSpec spec, const std::string& yaml,
                                                       const std::string& trigger, const std::string& owner);
  void launch(const std::shared_ptr<tasks::Run>& run);
  void on_trigger(const std::string& task, const planet::Event& event);
  void reap_locked();
  std::shared_ptr<tasks::Run> find_locked(const std::string& run_id) const;
  Result<Done> define_locked(const TaskSpec& spec, const std::string& yaml, const std::string& owner);
  // With mutex_ held, at start(): the stored runs; those found "running" are returned to resume.
  std::vector<std::shared_ptr<tasks::Run>> load_runs_locked();
  void notify_finished();

  const TaskManagerOptions options_;
  EventSource& events_;
  agent::EventSink& sink_;
  const Clock& clock_;
  const std::unique_ptr<tasks::TaskStore> store_;
  const std::unique_ptr<tasks::StepRunner> steps_;
  const std::unique_ptr<tasks::RunDriver> driver_;

  mutable std::mutex mutex_;
  std::map<std::string, Definition> definitions_;
  std::map<uint64_t, std::shared_ptr<tasks::Run>> runs_;  // by run number
  uint64_t next_run_ = 1;
  bool started_ = false;
  bool stopping_ = false;

  mutable std::mutex finished_mutex_;
  mutable std::condition_variable finished_cv_;

  // Last: disarmed (and its callbacks finished) before anything above is destroyed.
  const std::unique_ptr<tasks::TaskTriggers> triggers_;
};

}  // namespace urs::camus_server
