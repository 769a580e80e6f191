#include "liveliness_asserter.hpp"

#include <fastdds/dds/publisher/DataWriter.hpp>

namespace urs::federation {

LivelinessAsserter::LivelinessAsserter(std::chrono::milliseconds period)
    : period_(period), thread_([this] { run(); }) {}

LivelinessAsserter::~LivelinessAsserter() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_one();
  thread_.join();
}

void LivelinessAsserter::add(eprosima::fastdds::dds::DataWriter* writer) {
  std::lock_guard lock(mutex_);
  writers_.insert(writer);
}

void LivelinessAsserter::remove(eprosima::fastdds::dds::DataWriter* writer) {
  std::lock_guard lock(mutex_);  // not while the thread asserts
  writers_.erase(writer);
}

void LivelinessAsserter::run() {
  std::unique_lock lock(mutex_);
  while (!wake_.wait_for(lock, period_, [this] { return stopping_; })) {
    // Under the lock, so that remove() waits for this round. assert_liveliness() only queues a
    // heartbeat: it does not call back into this class.
    for (auto* writer : writers_) writer->assert_liveliness();
  }
}

}  // namespace urs::federation
