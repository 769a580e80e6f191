#include "client/io_thread.hpp"

#include <stdexcept>
#include <utility>

#include "link.hpp"

namespace urs::planet::detail {

IoThread::IoThread(std::shared_ptr<asio::io_context> io) : io_(std::move(io)) {}

IoThread::~IoThread() {
  work_.reset();
  if (thread_.joinable()) thread_.join();
}

void IoThread::start(std::function<void()> first) {
  std::lock_guard<std::mutex> lock(mutex_);  // the thread body does not take it
  if (started_ || stopping_) return;
  started_ = true;
  work_.emplace(io_->get_executor());
  thread_ = std::thread([this] {
    id_.store(std::this_thread::get_id());
    run_io(*io_, "client");
  });
  asio::post(*io_, std::move(first));
}

void IoThread::stop(std::function<void()> last) {
  bool was_started = false;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (stopping_) return;
    if (started_ && here()) {
      throw std::logic_error("planet::Client::stop() called from a callback on its I/O thread");
    }
    stopping_ = true;
    was_started = started_;
    // Posted under the lock: whatever post_or_keep() handed over before runs first.
    if (was_started) asio::post(*io_, std::move(last));
  }
  if (!was_started) {
    last();
    return;
  }
  work_.reset();
  thread_.join();
}

bool IoThread::started() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return started_;
}

bool IoThread::stopping() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return stopping_;
}

void IoThread::post_or_keep(Deferred& callbacks) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (callbacks.empty() || !started_ || stopping_ || here()) return;
  asio::post(*io_, [callbacks = std::move(callbacks)]() mutable { run_all(callbacks); });
  callbacks = Deferred();
}

}  // namespace urs::planet::detail
