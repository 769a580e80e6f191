#pragma once
// What each kind of task step does: call a service, wait for an event or a context entry, sleep,
// publish. Every wait blocks on the run's condition variable, so a cancel or a stop ends it at once
// (StepEnd::kStopped).
//
// Threading: run() is called on the run's own thread; it blocks for as long as the step lasts.

#include <memory>
#include <string>

#include "task_run.hpp"
#include "urs/agent/agent.hpp"
#include "urs/camus_server/context_store.hpp"
#include "urs/camus_server/event_bus.hpp"
#include "urs/camus_server/registry.hpp"
#include "urs/camus_server/task_manager.hpp"

namespace urs::camus_server::tasks {

class StepRunner {
 public:
  // Every reference must outlive the runner.
  StepRunner(Invoker& invoker, EventSource& events, const ContextReader& context, const SchemaLookup& schemas);

  // Runs `step` of `run`; on kFailed, `failure` says why ("STATUS: ...").
  StepEnd run(const std::shared_ptr<Run>& run, const TaskStep& step, std::string& failure);

 private:
  StepEnd call(const std::shared_ptr<Run>& run, const CallStep& step, std::string& failure);
  StepEnd wait_event(const std::shared_ptr<Run>& run, const WaitEventStep& step, std::string& failure);
  StepEnd wait_context(const std::shared_ptr<Run>& run, const WaitContextStep& step, std::string& failure);
  StepEnd sleep(const std::shared_ptr<Run>& run, const SleepStep& step);
  StepEnd publish(const Run& run, const PublishStep& step, std::string& failure);

  Invoker& invoker_;
  EventSource& events_;
  const ContextReader& context_;
  const SchemaLookup& schemas_;
};

}  // namespace urs::camus_server::tasks
