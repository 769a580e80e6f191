#pragma once
// LivelinessAsserter (internal to urs::bridge): asserts, every period, the liveliness of the
// DataWriters given to it, which offer MANUAL_BY_TOPIC liveliness (dds_qos.hpp says why not
// AUTOMATIC). A writer asserted so stays alive at its readers while this process runs, and is lost
// one lease after it stops (killed, paused, cut off), each writer on its own.
//
// Threads: its own thread asserts; add() and remove() may be called from any thread. remove()
// returns once the thread no longer touches the writer, which may then be deleted.

#include <chrono>
#include <condition_variable>
#include <mutex>
#include <set>
#include <thread>

namespace eprosima::fastdds::dds {
class DataWriter;
}

namespace urs::federation {

class LivelinessAsserter {
 public:
  explicit LivelinessAsserter(std::chrono::milliseconds period);
  ~LivelinessAsserter();  // stops and joins its thread
  LivelinessAsserter(const LivelinessAsserter&) = delete;
  LivelinessAsserter& operator=(const LivelinessAsserter&) = delete;

  void add(eprosima::fastdds::dds::DataWriter* writer);     // asserted from the next period on
  void remove(eprosima::fastdds::dds::DataWriter* writer);  // no longer asserted once this returns

 private:
  void run();

  const std::chrono::milliseconds period_;
  std::mutex mutex_;  // guards writers_ and stopping_; held while asserting
  std::condition_variable wake_;
  std::set<eprosima::fastdds::dds::DataWriter*> writers_;
  bool stopping_ = false;
  std::thread thread_;  // last: started once the rest exists
};

}  // namespace urs::federation
