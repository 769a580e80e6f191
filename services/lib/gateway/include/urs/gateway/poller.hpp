#pragma once
// Poller: a thread of its own that runs `work` at once, then whenever woken and at least every
// `period` — how a source reads what cannot be subscribed to (a registry, a naming service, a DDS
// reader's cache) without sleeping on a DDS or network thread. stop() wakes it and joins it (a run
// in progress ends first); wakes during a run make one more run.

#include <chrono>
#include <condition_variable>
#include <functional>
#include <mutex>
#include <thread>

namespace urs::gateway {

class Poller {
 public:
  Poller() = default;
  ~Poller() { stop(); }
  Poller(const Poller&) = delete;
  Poller& operator=(const Poller&) = delete;

  void start(std::chrono::milliseconds period, std::function<void()> work);
  void wake();  // any thread, never blocks
  void stop();  // idempotent; not from `work`

 private:
  void run(std::chrono::milliseconds period, const std::function<void()>& work);

  std::thread thread_;
  std::mutex mutex_;
  std::condition_variable wake_;
  bool woken_ = false;
  bool stopping_ = false;
};

}  // namespace urs::gateway
