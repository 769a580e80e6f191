#pragma once
// Task triggers: one internal event subscription per task that has a `trigger`, firing for every
// matching event (the task manager decides whether a run starts).
//
// Threading: thread-safe. `fire` runs on the event bus thread; after disarm_all() returns it runs
// no more (a call in progress has finished).

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>

#include "urs/camus_server/event_bus.hpp"
#include "urs/camus_server/task_spec.hpp"

namespace urs::camus_server::tasks {

class TaskTriggers {
 public:
  using Fire = std::function<void(const std::string& task, const planet::Event& event)>;
  // `events` must outlive the triggers.
  TaskTriggers(EventSource& events, Fire fire);
  ~TaskTriggers();  // disarm_all()
  TaskTriggers(const TaskTriggers&) = delete;
  TaskTriggers& operator=(const TaskTriggers&) = delete;

  // (Re)arms the trigger of `spec`, watching events from now on; a spec without one disarms the
  // task's. Does nothing after disarm_all().
  void arm(const TaskSpec& spec);
  void disarm_all();

 private:
  // Shared with the subscriptions' callbacks, which may outlive this object on the bus.
  struct Guard {
    std::mutex mutex;  // held while `fire` runs
    Fire fire;         // empty once disarmed
  };

  EventSource& events_;
  const std::shared_ptr<Guard> guard_;
  std::mutex mutex_;
  std::map<std::string, uint64_t> armed_;  // task -> internal subscription
  bool disarmed_ = false;
};

}  // namespace urs::camus_server::tasks
