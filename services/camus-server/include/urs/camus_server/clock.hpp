#pragma once
// Wall-clock source, injectable so that TTLs and timestamps can be tested without sleeping.

#include <atomic>
#include <chrono>
#include <cstdint>

namespace urs::camus_server {

class Clock {
 public:
  virtual ~Clock() = default;
  // Nanoseconds since the Unix epoch. Thread-safe.
  virtual int64_t now_unix_ns() const = 0;
};

class SystemClock final : public Clock {
 public:
  int64_t now_unix_ns() const override {
    return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::system_clock::now().time_since_epoch())
        .count();
  }
};

// A clock that moves only when told to (tests).
class ManualClock final : public Clock {
 public:
  explicit ManualClock(int64_t start_unix_ns = 1'700'000'000'000'000'000) : now_(start_unix_ns) {}
  int64_t now_unix_ns() const override { return now_.load(); }
  void advance(std::chrono::nanoseconds by) { now_ += by.count(); }

 private:
  std::atomic<int64_t> now_;
};

}  // namespace urs::camus_server
