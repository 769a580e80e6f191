#include "client/queue_budget.hpp"

#include <cassert>
#include <utility>

namespace urs::planet::detail {

QueueBudget::QueueBudget(size_t capacity, std::string target) : capacity_(capacity), target_(std::move(target)) {}

bool QueueBudget::try_take() {
  size_t used = used_.load();
  do {
    if (used >= capacity_) return false;
  } while (!used_.compare_exchange_weak(used, used + 1));
  return true;
}

void QueueBudget::take() { used_.fetch_add(1); }

void QueueBudget::give_back(size_t count) {
  [[maybe_unused]] const size_t before = used_.fetch_sub(count);
  assert(before >= count);
}

std::string QueueBudget::full_message(bool connected) const {
  if (connected) {
    return "the queue of " + std::to_string(capacity_) + " publishes awaiting acknowledgement from " + target_ +
           " is full";
  }
  return "not connected to " + target_ + " and the queue of " + std::to_string(capacity_) + " is full";
}

}  // namespace urs::planet::detail
