#pragma once
// glibc's heap in a long-running process that moves large messages now and then (a bridge, the
// gateway). glibc keeps what a process freed for its next allocations: after a burst of
// 921,600-byte calls a bridge held about 10 MiB of free heap pages resident, idle
// (docs/performance.md, "Bridge memory").
//
// Threading: use_few_arenas() before any other thread starts; a HeapTrimmer from any thread.

#include <chrono>
#include <condition_variable>
#include <mutex>
#include <thread>

namespace urs::util {

// At most two malloc arenas (glibc gives every thread that allocates one of its own, up to 8 per
// core), unless MALLOC_ARENA_MAX says otherwise.
void use_few_arenas();

// Hands the heap's free pages back to the system (malloc_trim) every `period` while it lives.
// What is in use is untouched; a later allocation maps the pages again (a page fault each).
class HeapTrimmer {
 public:
  explicit HeapTrimmer(std::chrono::milliseconds period);
  ~HeapTrimmer();  // stops and joins
  HeapTrimmer(const HeapTrimmer&) = delete;
  HeapTrimmer& operator=(const HeapTrimmer&) = delete;

 private:
  std::mutex mutex_;
  std::condition_variable stop_;
  bool stopping_ = false;
  std::thread thread_;
};

}  // namespace urs::util
