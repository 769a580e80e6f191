#pragma once
// Reloading a running server's files (SIGHUP) off the thread that waits for signals, so that a
// reload, whatever it reads, never delays the reaction to SIGTERM.

#include <condition_variable>
#include <functional>
#include <mutex>
#include <thread>

namespace urs::util {

// Runs `reload` on a thread of its own for each request(); requests that arrive while a reload
// runs are merged into one more run after it. `reload` must not throw (it logs its failures) and
// must read its files so that it cannot block (util::read_regular_file).
//
// Threading: request() from any thread, never blocks. The destructor lets a reload in progress
// end, drops the requests not started and joins.
class ReloadWorker {
 public:
  explicit ReloadWorker(std::function<void()> reload);
  ~ReloadWorker();
  ReloadWorker(const ReloadWorker&) = delete;
  ReloadWorker& operator=(const ReloadWorker&) = delete;

  void request();
  // Blocks until every reload requested before the call has run (tests).
  void wait_idle();

 private:
  void run();

  const std::function<void()> reload_;
  std::mutex mutex_;
  std::condition_variable changed_;
  bool requested_ = false;
  bool running_ = false;
  bool stopping_ = false;
  std::thread thread_;
};

}  // namespace urs::util
