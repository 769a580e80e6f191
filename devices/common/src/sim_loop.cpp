#include "urs/devices/sim_loop.hpp"

#include <chrono>
#include <stdexcept>

namespace urs::devices {

void SimLoop::start(double period, double time_scale, std::function<void()> tick) {
  if (thread_.joinable()) throw std::logic_error("SimLoop::start: already running");
  stopping_ = false;
  const auto wall_period = std::chrono::duration_cast<std::chrono::steady_clock::duration>(
      std::chrono::duration<double>(period / time_scale));
  thread_ = std::thread([this, wall_period, tick = std::move(tick)] {
    auto next = std::chrono::steady_clock::now();
    std::unique_lock<std::mutex> lock(mutex_);
    while (!stopping_) {
      lock.unlock();
      tick();
      lock.lock();
      next += wall_period;
      // A loaded machine delays ticks; after a long stall, resume the pace instead of catching
      // up in a burst (simulated time then lags the wall clock, which nothing depends on).
      const auto now = std::chrono::steady_clock::now();
      if (now > next + 10 * wall_period) next = now;
      wake_.wait_until(lock, next, [this] { return stopping_; });
    }
  });
}

void SimLoop::stop() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
}

}  // namespace urs::devices
