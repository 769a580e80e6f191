#pragma once
// ClientOptions::max_queued: one bound shared by the calls waiting for a connection and the
// publishes waiting for the server's acknowledgement. Thread-safe (lock-free).

#include <atomic>
#include <cstddef>
#include <string>

namespace urs::planet::detail {

class QueueBudget {
 public:
  // `target` ("host:port") names the server in refusals.
  QueueBudget(size_t capacity, std::string target);

  // Takes one place if one is free.
  bool try_take();
  // Takes one place even beyond the capacity (a call queued behind others while connected: the
  // bound applies to what is accepted without a connection).
  void take();
  void give_back(size_t count = 1);
  size_t used() const { return used_.load(); }

  // The refusal when full: `connected` says whether a session is open (then what fills the queue
  // are publishes awaiting acknowledgement).
  std::string full_message(bool connected) const;

 private:
  const size_t capacity_;
  const std::string target_;
  std::atomic<size_t> used_{0};
};

}  // namespace urs::planet::detail
