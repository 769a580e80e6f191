#pragma once
// RpcRegistrations (internal to urs::bridge): the requests and replies the DdsLink's writers keep
// registered, each until nobody waits for it any more: then it is unregistered, so that a reader
// that matches later does not get it (one that has it already keeps it). Oneway requests and
// replies are kept until a time (retire_later), a reply also until its caller is done with it
// (retire_reply); a call's own request is retired by its caller at once (retire).
//
// Threads: any; its own lock, held while unregistering (a Fast DDS call that does not call back).

#include <chrono>
#include <deque>
#include <mutex>
#include <string>

namespace eprosima::fastdds::dds {
class DataWriter;
}

namespace urs::federation {

class RpcRegistrations {
 public:
  using Clock = std::chrono::steady_clock;

  // The request (or reply) `id` is no longer waited for: unregistered on `writer`.
  static void retire(eprosima::fastdds::dds::DataWriter* writer, const std::string& id, bool reply);
  // Keeps `id` registered on `writer` until `until`, and retires what is due.
  void retire_later(eprosima::fastdds::dds::DataWriter* writer, const std::string& id, bool reply,
                    Clock::time_point until);
  // The reply to `id`, if still registered, is retired now.
  void retire_reply(const std::string& id);

 private:
  struct Registered {
    Clock::time_point until;
    eprosima::fastdds::dds::DataWriter* writer;
    std::string request_id;
    bool reply;
  };
  std::mutex mutex_;                   // guards registered_
  std::deque<Registered> registered_;  // oneway requests and replies, by `until` within each kind
};

}  // namespace urs::federation
