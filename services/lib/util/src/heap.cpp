#include "urs/util/heap.hpp"

#include <malloc.h>

#include <cstdlib>

namespace urs::util {

void use_few_arenas() {
  if (std::getenv("MALLOC_ARENA_MAX") == nullptr) mallopt(M_ARENA_MAX, 2);
}

HeapTrimmer::HeapTrimmer(std::chrono::milliseconds period)
    : thread_([this, period] {
        std::unique_lock<std::mutex> lock(mutex_);
        while (!stop_.wait_for(lock, period, [this] { return stopping_; })) malloc_trim(0);
      }) {}

HeapTrimmer::~HeapTrimmer() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
  }
  stop_.notify_all();
  thread_.join();
}

}  // namespace urs::util
