#include "task_runner.hpp"

#include <spdlog/spdlog.h>

namespace urs::camus_server::tasks {

RunDriver::RunDriver(TaskStore& store, StepRunner& steps, EventSource& events, agent::EventSink& sink,
                     const Clock& clock, std::function<void()> finished)
    : store_(store), steps_(steps), events_(events), sink_(sink), clock_(clock), finished_(std::move(finished)) {}

void RunDriver::finish(const std::shared_ptr<Run>& run, const std::string& state, const std::string& message) {
  camus::TaskRun snapshot;
  {
    std::lock_guard<std::mutex> lock(run->mutex);
    if (run->cancelled || run->state.state() != kRunning) return;
    run->state.set_state(state);
    run->state.set_message(message);
    run->state.set_finished_unix_ns(clock_.now_unix_ns());
    store_.save(*run);
    snapshot = run->state;
  }
  if (state == kFailed) {
    spdlog::warn("task '{}' run {} failed: {}", snapshot.task(), snapshot.run_id(), message);
  } else {
    spdlog::info("task '{}' run {} {}", snapshot.task(), snapshot.run_id(), state);
  }
  publish_progress(sink_, snapshot);
  finished_();
}

void RunDriver::execute(const std::shared_ptr<Run>& run) {
  const TaskSpec& spec = run->spec;
  uint32_t iteration;
  uint32_t step;
  {
    std::lock_guard<std::mutex> lock(run->mutex);
    iteration = run->iteration;
    step = run->state.step();
  }
  auto exit = [&run] {
    std::lock_guard<std::mutex> lock(run->mutex);
    run->exited = true;
  };
  for (; iteration < spec.repeat; ++iteration, step = 0) {
    for (; step < spec.steps.size(); ++step) {
      const TaskStep& current = spec.steps[step];
      camus::TaskRun snapshot;
      std::string prefix;
      {
        std::lock_guard<std::mutex> lock(run->mutex);
        if (run->stop_requested()) {
          run->exited = true;  // (exit() would lock again)
          return;
        }
        bool resumed = run->resuming;
        run->resuming = false;
        run->iteration = iteration;
        run->state.set_step(step);
        bool is_call = std::holds_alternative<CallStep>(current.action);
        // wait_event looks at events after the latest call (or the iteration's start); the
        // first iteration starts where the run did, so events right after Run are not missed.
        if (is_call || (step == 0 && iteration > 0 && !resumed)) run->watch_seq = events_.last_seq();
        prefix = run->prefix();
        run->state.set_message(prefix + "steps[" + std::to_string(step) + "]: " + current.summary());
        store_.save(*run);
        snapshot = run->state;
      }
      publish_progress(sink_, snapshot);
      std::string failure;
      StepEnd end = steps_.run(run, current, failure);
      if (end == StepEnd::kStopped) return exit();
      if (end == StepEnd::kFailed) {
        finish(run, kFailed,
               prefix + "steps[" + std::to_string(step) + "] (" + current.summary() + ") failed: " + failure);
        return exit();
      }
    }
  }
  std::string done = "completed " + std::to_string(spec.steps.size()) + " steps";
  if (spec.repeat > 1) done += " " + std::to_string(spec.repeat) + " times";
  finish(run, kSucceeded, done);
  exit();
}

}  // namespace urs::camus_server::tasks
