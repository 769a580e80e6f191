#pragma once
// One-shot timers. The router's call deadlines and the context store's TTL purges use them.

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <map>
#include <mutex>
#include <set>
#include <thread>
#include <unordered_map>
#include <utility>
#include <vector>

namespace urs::camus_server {

class Scheduler {
 public:
  using TimerId = uint64_t;
  using Callback = std::function<void()>;
  virtual ~Scheduler() = default;
  // Runs `callback` once, `delay` from now, on the scheduler's thread; the callback must not block.
  // Thread-safe; never blocks. Ids are never 0.
  virtual TimerId schedule_after(std::chrono::milliseconds delay, Callback callback) = 0;
  // True if the timer was still pending (it will not run). Thread-safe; never blocks on a
  // running callback.
  virtual bool cancel(TimerId id) = 0;
};

// A single thread sleeping on a condition variable until the earliest deadline of an ordered set.
// A cancelled timer is removed at once (a call answered long before its 24 h deadline leaves
// nothing behind). Callbacks run on that thread, outside its lock.
class TimerThread final : public Scheduler {
 public:
  TimerThread();
  ~TimerThread() override;  // stop()
  TimerThread(const TimerThread&) = delete;
  TimerThread& operator=(const TimerThread&) = delete;

  TimerId schedule_after(std::chrono::milliseconds delay, Callback callback) override;
  bool cancel(TimerId id) override;
  // Joins the thread; pending timers are dropped without running. Idempotent.
  void stop();
  size_t pending() const;

 private:
  using TimePoint = std::chrono::steady_clock::time_point;
  void run();

  struct Timer {
    TimePoint due;
    Callback callback;
  };
  mutable std::mutex mutex_;
  std::condition_variable wake_;
  std::set<std::pair<TimePoint, TimerId>> order_;  // pending timers, earliest first
  std::unordered_map<TimerId, Timer> timers_;
  TimerId next_id_ = 1;
  bool stopping_ = false;
  std::thread thread_;
};

// A scheduler whose time moves only through advance() (tests). Callbacks run inside advance(),
// on the calling thread, in deadline order.
class ManualScheduler final : public Scheduler {
 public:
  TimerId schedule_after(std::chrono::milliseconds delay, Callback callback) override;
  bool cancel(TimerId id) override;
  void advance(std::chrono::milliseconds by);
  size_t pending() const;

 private:
  mutable std::mutex mutex_;
  std::chrono::milliseconds now_{0};
  std::multimap<std::chrono::milliseconds, std::pair<TimerId, Callback>> timers_;
  TimerId next_id_ = 1;
};

}  // namespace urs::camus_server
