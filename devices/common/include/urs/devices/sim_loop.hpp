#pragma once
// A periodic thread on simulated time: `tick` runs once per `period` simulated seconds, and
// simulated time runs `time_scale` times faster than the wall clock (10 = ten times faster), so
// tests can drive a simulated device through minutes of motion in seconds.

#include <condition_variable>
#include <functional>
#include <mutex>
#include <thread>

namespace urs::devices {

class SimLoop {
 public:
  SimLoop() = default;
  ~SimLoop() { stop(); }
  SimLoop(const SimLoop&) = delete;
  SimLoop& operator=(const SimLoop&) = delete;

  // Starts the thread; `tick` must not call stop(). Throws std::logic_error if already running.
  void start(double period, double time_scale, std::function<void()> tick);
  // Wakes the thread, waits for the running tick to end and joins. Idempotent.
  void stop();

 private:
  std::mutex mutex_;
  std::condition_variable wake_;
  bool stopping_ = false;
  std::thread thread_;
};

}  // namespace urs::devices
