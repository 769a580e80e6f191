// HeapTrimmer: the heap's free pages go back to the system while it runs.

#include "urs/util/heap.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <cstring>
#include <fstream>
#include <thread>
#include <vector>

namespace urs::util {
namespace {

long resident_kib() {
  long pages = 0, resident = 0;
  std::ifstream("/proc/self/statm") >> pages >> resident;
  return resident * (sysconf(_SC_PAGESIZE) / 1024);
}

TEST(HeapTrimmer, HandsTheHeapsFreePagesBackToTheSystem) {
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
  GTEST_SKIP() << "the sanitizer's allocator stands in for glibc's heap";
#endif
  // 64 MiB in 64 KiB blocks (below the mmap threshold: from the heap), written, then every other
  // one freed: holes that glibc keeps resident, as the top of the heap stays in use.
  constexpr size_t kBlock = 64u << 10;
  std::vector<char*> blocks;
  for (int i = 0; i < 1024; ++i) {
    blocks.push_back(static_cast<char*>(std::malloc(kBlock)));
    std::memset(blocks.back(), i, kBlock);
  }
  const long in_use = resident_kib();
  for (size_t i = 0; i < blocks.size(); i += 2) std::free(blocks[i]);
  const long freed = resident_kib();
  ASSERT_GT(freed, in_use - 8 * 1024) << "glibc handed the pages back by itself: this test would show nothing";

  {
    const HeapTrimmer trimmer(std::chrono::milliseconds(20));
    for (int i = 0; i < 250 && resident_kib() > freed - 24 * 1024; ++i) {
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
  }
  EXPECT_LT(resident_kib(), freed - 24 * 1024) << "resident before the trimmer: " << freed << " KiB";
  for (size_t i = 1; i < blocks.size(); i += 2) std::free(blocks[i]);
}

TEST(HeapTrimmer, StopsAtOnceWhenDestroyed) {
  const auto started = std::chrono::steady_clock::now();
  { const HeapTrimmer trimmer(std::chrono::milliseconds(20)); }
  EXPECT_LT(std::chrono::steady_clock::now() - started, std::chrono::seconds(30));
}

}  // namespace
}  // namespace urs::util
