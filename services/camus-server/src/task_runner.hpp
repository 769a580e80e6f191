#pragma once
// Drives a run through its steps, iteration after iteration, on the run's own thread: before each
// step the run's progress is stored, then published; the run ends succeeded, failed (naming the
// step and why), or stopped (cancelled, or interrupted by a server stop: it then stays "running"
// in the store and resumes at its current step on the next start).

#include <functional>
#include <memory>
#include <string>

#include "task_run.hpp"
#include "task_steps.hpp"
#include "task_store.hpp"
#include "urs/camus_server/clock.hpp"

namespace urs::camus_server::tasks {

class RunDriver {
 public:
  // Every reference must outlive the driver. `finished` runs after a run ended (any thread).
  RunDriver(TaskStore& store, StepRunner& steps, EventSource& events, agent::EventSink& sink, const Clock& clock,
            std::function<void()> finished);

  // The body of the run's thread; returns when the run ended or was stopped.
  void execute(const std::shared_ptr<Run>& run);

 private:
  // Ends a run still "running" with `state` (succeeded or failed) and `message`.
  void finish(const std::shared_ptr<Run>& run, const std::string& state, const std::string& message);

  TaskStore& store_;
  StepRunner& steps_;
  EventSource& events_;
  agent::EventSink& sink_;
  const Clock& clock_;
  const std::function<void()> finished_;
};

}  // namespace urs::camus_server::tasks
