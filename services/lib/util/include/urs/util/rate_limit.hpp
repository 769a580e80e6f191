#pragma once
// Log rate limiting by key (e.g. a peer's address): a hostile peer must not be able to fill the
// log. Each key may log `burst` messages per `window`; what it could not log is counted and
// reported with its next message that gets through.

#include <chrono>
#include <cstdint>
#include <mutex>
#include <string>
#include <unordered_map>

namespace urs::util {

class RateLimiter {
 public:
  // At most `max_keys` keys are tracked; beyond them (a flood of addresses) all others share one.
  RateLimiter(size_t burst, std::chrono::milliseconds window, size_t max_keys = 4096);

  // Whether a message under `key` may be logged now. When it may, `suppressed` is the number of
  // messages under that key that were not since the last one that was. Thread-safe.
  bool allow(const std::string& key, uint64_t& suppressed);

 private:
  struct Entry {
    std::chrono::steady_clock::time_point window_start;
    size_t logged = 0;
    uint64_t suppressed = 0;
  };
  const size_t burst_;
  const std::chrono::milliseconds window_;
  const size_t max_keys_;
  std::mutex mutex_;
  std::unordered_map<std::string, Entry> entries_;
};

// The suffix a rate-limited message gets: "" or " (N similar messages suppressed)".
std::string suppressed_note(uint64_t suppressed);

}  // namespace urs::util
