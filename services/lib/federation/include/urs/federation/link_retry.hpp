#pragma once
// Joining the DDS link until it is joined: a link that cannot be joined yet (an initial peer or
// discovery server whose name resolves only once its container has started) is tried again every
// LinkRetry::kPeriod while the rest of the program works. Says why once per distinct reason, and
// that the link was joined once it is after a failure. Used by the bridge's run loop and the
// gateway's DDS source, each from one thread.

#include <chrono>
#include <string>
#include <utility>

namespace urs::federation {

class LinkRetry {
 public:
  using Clock = std::chrono::steady_clock;
  static constexpr std::chrono::seconds kPeriod{2};

  // `who` starts each log line, e.g. "bridge bridge-kr" or "gateway".
  explicit LinkRetry(std::string who) : who_(std::move(who)) {}

  // When the next try is due (at once before the first failure).
  Clock::time_point next_try() const { return next_try_; }
  bool due(Clock::time_point now) const { return now >= next_try_; }

  // The try failed for `why`: logged unless it is the last failure's reason; the next is due in kPeriod.
  void failed(const std::string& why);
  // The try joined the link: logged if an earlier one had failed.
  void joined();

 private:
  const std::string who_;
  std::string failure_;  // why the last try failed; empty: joined, or not tried yet
  Clock::time_point next_try_{};
};

}  // namespace urs::federation
