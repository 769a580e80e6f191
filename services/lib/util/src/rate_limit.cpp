#include "urs/util/rate_limit.hpp"

namespace urs::util {

RateLimiter::RateLimiter(size_t burst, std::chrono::milliseconds window, size_t max_keys)
    : burst_(burst), window_(window), max_keys_(max_keys) {}

bool RateLimiter::allow(const std::string& key, uint64_t& suppressed) {
  const auto now = std::chrono::steady_clock::now();
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = entries_.find(key);
  if (it == entries_.end()) {
    if (entries_.size() >= max_keys_) {
      // Forget the keys whose window is over and that have nothing to report, then share one.
      for (auto e = entries_.begin(); e != entries_.end();) {
        e = (now - e->second.window_start >= window_ && e->second.suppressed == 0) ? entries_.erase(e) : std::next(e);
      }
    }
    const std::string& slot = entries_.size() >= max_keys_ ? std::string("(other peers)") : key;
    it = entries_.try_emplace(slot, Entry{now, 0, 0}).first;
  }
  Entry& entry = it->second;
  if (now - entry.window_start >= window_) {
    entry.window_start = now;
    entry.logged = 0;
  }
  if (entry.logged >= burst_) {
    ++entry.suppressed;
    return false;
  }
  ++entry.logged;
  suppressed = entry.suppressed;
  entry.suppressed = 0;
  return true;
}

std::string suppressed_note(uint64_t suppressed) {
  if (suppressed == 0) return {};
  return " (" + std::to_string(suppressed) + " similar message" + (suppressed == 1 ? "" : "s") + " suppressed)";
}

}  // namespace urs::util
