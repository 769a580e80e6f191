#include "urs/gateway/poller.hpp"

namespace urs::gateway {

void Poller::start(std::chrono::milliseconds period, std::function<void()> work) {
  thread_ = std::thread([this, period, work = std::move(work)] { run(period, work); });
}

void Poller::wake() {
  {
    std::lock_guard lock(mutex_);
    woken_ = true;
  }
  wake_.notify_one();
}

void Poller::stop() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_one();
  if (thread_.joinable()) thread_.join();
}

void Poller::run(std::chrono::milliseconds period, const std::function<void()>& work) {
  std::unique_lock lock(mutex_);
  while (!stopping_) {
    woken_ = false;
    lock.unlock();
    work();
    lock.lock();
    wake_.wait_for(lock, period, [&] { return woken_ || stopping_; });
  }
}

}  // namespace urs::gateway
