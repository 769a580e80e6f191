#pragma once
// A FrameSink that records what the client's components send, or refuses like a closing connection.

#include <condition_variable>
#include <mutex>
#include <vector>

#include "client/frame_sink.hpp"

namespace urs::planet::detail {

class RecordingSink final : public FrameSink {
 public:
  bool send(Frame&& frame) override {
    std::lock_guard<std::mutex> lock(mutex_);
    if (refusing_) return false;
    frames_.push_back(std::move(frame));
    changed_.notify_all();
    return true;
  }
  void refuse(bool refusing) {
    std::lock_guard<std::mutex> lock(mutex_);
    refusing_ = refusing;
  }
  std::vector<Frame> frames() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return frames_;
  }
  void clear() {
    std::lock_guard<std::mutex> lock(mutex_);
    frames_.clear();
  }
  // Blocks until `count` frames were sent.
  void wait_for_frames(size_t count) {
    std::unique_lock<std::mutex> lock(mutex_);
    changed_.wait(lock, [&] { return frames_.size() >= count; });
  }

 private:
  mutable std::mutex mutex_;
  std::condition_variable changed_;
  std::vector<Frame> frames_;
  bool refusing_ = false;
};

}  // namespace urs::planet::detail
