#include "urs/camus_server/timer.hpp"

namespace urs::camus_server {

TimerThread::TimerThread() : thread_([this] { run(); }) {}

TimerThread::~TimerThread() { stop(); }

Scheduler::TimerId TimerThread::schedule_after(std::chrono::milliseconds delay, Callback callback) {
  std::lock_guard<std::mutex> lock(mutex_);
  TimerId id = next_id_++;
  if (stopping_) return id;  // dropped, like every pending timer at stop()
  auto due = std::chrono::steady_clock::now() + delay;
  bool earliest = order_.empty() || due < order_.begin()->first;
  order_.emplace(due, id);
  timers_.emplace(id, Timer{due, std::move(callback)});
  if (earliest) wake_.notify_one();
  return id;
}

bool TimerThread::cancel(TimerId id) {
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = timers_.find(id);
  if (it == timers_.end()) return false;
  order_.erase({it->second.due, id});
  timers_.erase(it);
  return true;
}

size_t TimerThread::pending() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return timers_.size();
}

void TimerThread::stop() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
    order_.clear();
    timers_.clear();
    wake_.notify_all();
  }
  if (thread_.joinable()) thread_.join();
}

void TimerThread::run() {
  std::unique_lock<std::mutex> lock(mutex_);
  while (!stopping_) {
    if (order_.empty()) {
      wake_.wait(lock);
      continue;
    }
    auto [due, id] = *order_.begin();
    if (std::chrono::steady_clock::now() < due) {
      wake_.wait_until(lock, due);
      continue;  // re-examine: woken early, a new earlier timer, a cancel, or stop
    }
    order_.erase(order_.begin());
    auto timer = timers_.find(id);
    Callback callback = std::move(timer->second.callback);
    timers_.erase(timer);
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
