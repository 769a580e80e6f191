#include "urs/camus_server/timer.hpp"

namespace urs::camus_server {

TimerThread::TimerThread() : thread_([this] { run(); }) {}

TimerThread::~TimerThread() { stop(); }

Scheduler::TimerId TimerThread::schedule_after(std::chrono::milliseconds delay, Callback callback) {
  std::lock_guard<std::mutex> lock(mutex_);
  TimerId id = next_id_++;
  if (stopping_) return id;  // dropped, like every pending timer at stop()
  auto due = std::chrono::steady_clock::now() + delay;
  bool earliest = heap_.empty() || due < heap_.top().first;
  heap_.emplace(due, id);
  callbacks_.emplace(id, std::move(callback));
  if (earliest) wake_.notify_one();
  return id;
}

bool TimerThread::cancel(TimerId id) {
  std::lock_guard<std::mutex> lock(mutex_);
  // The heap entry stays until it comes due; run() skips ids without a callback.
  return callbacks_.erase(id) > 0;
}

void TimerThread::stop() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
    callbacks_.clear();
    wake_.notify_all();
  }
  if (thread_.joinable()) thread_.join();
}

void TimerThread::run() {
  std::unique_lock<std::mutex> lock(mutex_);
  while (!stopping_) {
    if (heap_.empty()) {
      wake_.wait(lock);
      continue;
    }
    auto [due, id] = heap_.top();
    if (callbacks_.count(id) == 0) {  // cancelled
      heap_.pop();
      continue;
    }
    if (std::chrono::steady_clock::now() < due) {
      wake_.wait_until(lock, due);
      continue;  // re-examine: woken early, a new earlier timer, or stop
    }
    heap_.pop();
    Callback callback = std::move(callbacks_[id]);
    callbacks_.erase(id);
    lock.unlock();
    callback();
    lock.lock();
  }
}

Scheduler::TimerId ManualScheduler::schedule_after(std::chrono::milliseconds delay, Callback callback) {
  std::lock_guard<std::mutex> lock(mutex_);
  TimerId id = next_id_++;
  timers_.emplace(now_ + delay, std::make_pair(id, std::move(callback)));
  return id;
}

bool ManualScheduler::cancel(TimerId id) {
  std::lock_guard<std::mutex> lock(mutex_);
  for (auto it = timers_.begin(); it != timers_.end(); ++it) {
    if (it->second.first == id) {
      timers_.erase(it);
      return true;
    }
  }
  return false;
}

void ManualScheduler::advance(std::chrono::milliseconds by) {
  std::chrono::milliseconds target;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    target = now_ + by;
  }
  for (;;) {
    Callback callback;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      auto it = timers_.begin();
      if (it == timers_.end() || it->first > target) {
        now_ = target;
        return;
      }
      now_ = it->first;
      callback = std::move(it->second.second);
      timers_.erase(it);
    }
    callback();
  }
}

size_t ManualScheduler::pending() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return timers_.size();
}

}  // namespace urs::camus_server
