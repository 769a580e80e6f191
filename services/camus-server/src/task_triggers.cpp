#include "task_triggers.hpp"

namespace urs::camus_server::tasks {

TaskTriggers::TaskTriggers(EventSource& events, Fire fire) : events_(events), guard_(std::make_shared<Guard>()) {
  guard_->fire = std::move(fire);
}

TaskTriggers::~TaskTriggers() { disarm_all(); }

void TaskTriggers::arm(const TaskSpec& spec) {
  std::lock_guard<std::mutex> lock(mutex_);
  auto old = armed_.find(spec.name);
  if (old != armed_.end()) {
    events_.unsubscribe_internal(old->second);
    armed_.erase(old);
  }
  if (spec.trigger.empty() || disarmed_) return;
  armed_[spec.name] = events_.subscribe_internal(spec.trigger_pattern, events_.last_seq(),
                                                 [guard = guard_, task = spec.name](const planet::Event& event) {
                                                   std::lock_guard<std::mutex> fire_lock(guard->mutex);
                                                   if (guard->fire) guard->fire(task, event);
                                                   return true;
                                                 });
}

void TaskTriggers::disarm_all() {
  {
    std::lock_guard<std::mutex> fire_lock(guard_->mutex);
    guard_->fire = nullptr;
  }
  std::lock_guard<std::mutex> lock(mutex_);
  disarmed_ = true;
  for (auto& [task, handle] : armed_) events_.unsubscribe_internal(handle);
  armed_.clear();
}

}  // namespace urs::camus_server::tasks
