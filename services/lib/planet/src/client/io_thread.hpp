#pragma once
// The client's one I/O thread: runs the io_context from start() until stop(). The connection, the
// deadline timers and the callbacks of the client all run there.
//
// Threading: thread-safe.

#include <asio.hpp>
#include <atomic>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>

#include "client/deferred.hpp"

namespace urs::planet::detail {

class IoThread {
 public:
  explicit IoThread(std::shared_ptr<asio::io_context> io);
  ~IoThread();  // joins the thread if stop() was not called (it must have been told to finish)
  IoThread(const IoThread&) = delete;
  IoThread& operator=(const IoThread&) = delete;

  // Starts the thread and posts `first` to it; does nothing once started or stopping.
  void start(std::function<void()> first);
  // Runs `last` on the thread, lets it finish and joins it; without a thread ever started, runs
  // `last` here. Once only (later calls return at once). Throws std::logic_error from the I/O
  // thread itself, which cannot join itself.
  void stop(std::function<void()> last);

  bool started() const;
  bool stopping() const;
  bool here() const { return std::this_thread::get_id() == id_.load(); }

  // Hands `callbacks` to the thread if it runs and this is another thread (they then run before
  // stop() joins it) and clears them; else leaves them for the caller to run.
  void post_or_keep(Deferred& callbacks);

 private:
  const std::shared_ptr<asio::io_context> io_;
  std::optional<asio::executor_work_guard<asio::io_context::executor_type>> work_;
  std::thread thread_;
  std::atomic<std::thread::id> id_{};
  mutable std::mutex mutex_;
  bool started_ = false;
  bool stopping_ = false;
};

}  // namespace urs::planet::detail
