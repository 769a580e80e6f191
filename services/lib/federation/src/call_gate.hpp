#pragma once
// CallGate (internal to urs::bridge): the DdsLink's calls in progress (call(), oneway(), a reply
// being written) against its closing. A call admitted (InProgress) may use the link's writers until
// it ends; close() admits no more, and wait_idle() returns once every admitted one has ended: the
// link's destructor deletes its endpoints only then.
//
// Threads: any; InProgress never blocks, wait_idle() blocks (the destructor only).

#include <atomic>
#include <condition_variable>
#include <mutex>

namespace urs::federation {

class CallGate {
 public:
  class InProgress {
   public:
    explicit InProgress(CallGate& gate) : gate_(gate) {
      std::lock_guard lock(gate_.mutex_);
      admitted_ = !gate_.closing_;
      if (admitted_) ++gate_.in_progress_;
    }
    ~InProgress() {
      if (!admitted_) return;
      std::lock_guard lock(gate_.mutex_);
      if (--gate_.in_progress_ == 0) gate_.done_.notify_all();
    }
    InProgress(const InProgress&) = delete;
    InProgress& operator=(const InProgress&) = delete;
    bool admitted() const { return admitted_; }

   private:
    CallGate& gate_;
    bool admitted_ = false;
  };

  bool closing() const { return closing_; }
  void close() {
    std::lock_guard lock(mutex_);
    closing_ = true;
  }
  void wait_idle() {
    std::unique_lock lock(mutex_);
    done_.wait(lock, [&] { return in_progress_ == 0; });
  }

 private:
  std::atomic<bool> closing_{false};
  std::mutex mutex_;  // guards in_progress_ and the setting of closing_
  std::condition_variable done_;
  int in_progress_ = 0;
};

}  // namespace urs::federation
