#pragma once
// One task run as the task manager's components share it: its definition snapshot, its progress
// (camus::TaskRun) and the condition variable every wait of its thread blocks on, so that Cancel
// and stop take effect at once whatever the step.

#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <string>
#include <thread>

#include "camus.pb.h"
#include "urs/agent/agent.hpp"
#include "urs/camus_server/task_spec.hpp"

namespace urs::camus_server::tasks {

// TaskRun.state values.
inline constexpr const char* kRunning = "running";
inline constexpr const char* kSucceeded = "succeeded";
inline constexpr const char* kFailed = "failed";
inline constexpr const char* kCancelled = "cancelled";

struct Run {
  uint64_t number = 0;
  std::string run_id;  // "r<number>"
  TaskSpec spec;
  std::string yaml;
  std::string owner;  // whose name its publish steps carry (TaskManager); empty: "task:<task>/<run>"

  // The source of the run's `publish` steps.
  std::string publisher() const { return owner.empty() ? "task:" + spec.name + "/" + run_id : owner; }

  std::mutex mutex;  // guards what follows; the run's waits block on cv under it
  std::condition_variable cv;
  camus::TaskRun state;
  uint32_t iteration = 0;
  uint64_t watch_seq = 0;    // wait_event looks at events after this seq
  bool resuming = false;     // the current step was started before a restart
  bool cancelled = false;    // cancel() has written the final state
  bool interrupted = false;  // the server is stopping; the run stays "running" in the store
  bool exited = false;       // the run's thread has returned
  std::thread thread;

  bool stop_requested() const { return cancelled || interrupted; }
  // "iteration 2/5, " for a repeated task, else empty: the start of every progress message.
  std::string prefix() const {
    return spec.repeat > 1 ? "iteration " + std::to_string(iteration + 1) + "/" + std::to_string(spec.repeat) + ", "
                           : std::string();
  }
};

// How a step ended.
enum class StepEnd { kNext, kFailed, kStopped };

// Publishes a run's progress on "task/<task>/<run_id>".
inline void publish_progress(agent::EventSink& sink, const camus::TaskRun& snapshot) {
  sink.publish("task/" + snapshot.task() + "/" + snapshot.run_id(), snapshot);
}

}  // namespace urs::camus_server::tasks
