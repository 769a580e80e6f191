#include "urs/util/reload.hpp"

namespace urs::util {

ReloadWorker::ReloadWorker(std::function<void()> reload) : reload_(std::move(reload)), thread_([this] { run(); }) {}

ReloadWorker::~ReloadWorker() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
  }
  changed_.notify_all();
  thread_.join();
}

void ReloadWorker::request() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    requested_ = true;
  }
  changed_.notify_all();
}

void ReloadWorker::wait_idle() {
  std::unique_lock<std::mutex> lock(mutex_);
  changed_.wait(lock, [this] { return stopping_ || (!requested_ && !running_); });
}

void ReloadWorker::run() {
  std::unique_lock<std::mutex> lock(mutex_);
  for (;;) {
    changed_.wait(lock, [this] { return stopping_ || requested_; });
    if (stopping_) return;
    requested_ = false;
    running_ = true;
    lock.unlock();
    reload_();
    lock.lock();
    running_ = false;
    changed_.notify_all();
  }
}

}  // namespace urs::util
