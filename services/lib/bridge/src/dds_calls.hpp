#pragma once
// DdsCalls (internal to urs::bridge): the calling side of the DdsLink. A request writer per target
// space (made at its first call, with a listener that follows its matched readers), the calls
// waiting for their replies by request id, this space's reply reader; call() and oneway() as
// DdsLink's, after the link admitted them (CallGate) and checked the space's liveliness.
//
// Threads: call() and oneway() block (a first match, then the reply): never on a DDS listener or
// Planet I/O thread. read_replies() and fail_pending() on DDS listener threads; close() from the
// link's destructor. Its lock guards the writers and the pending calls, and is never held while a
// caller is woken or Fast DDS writes.

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <future>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include <fastdds/dds/publisher/DataWriterListener.hpp>

#include "call_gate.hpp"
#include "dds_identity.hpp"
#include "dds_participant.hpp"
#include "rpc_registrations.hpp"
#include "urs/bridge/dds_link.hpp"

namespace urs::bridge {

class DdsCalls {
 public:
  using Clock = std::chrono::steady_clock;

  // `identities` says which space wrote each reply: on a secured link only the called space's are taken.
  DdsCalls(const DdsOptions& options, LinkParticipant& participant, CallGate& gate, RpcRegistrations& registrations,
           DdsIdentities& identities);
  DdsCalls(const DdsCalls&) = delete;
  DdsCalls& operator=(const DdsCalls&) = delete;

  // Creates the reply reader with `listener` (which hands its data to read_replies()); throws
  // std::runtime_error if DDS refuses.
  void open(eprosima::fastdds::dds::DataReaderListener* listener);
  const std::string& reply_name() const { return reply_name_; }  // the reply reader's topic

  // DdsLink::call() and oneway(), once admitted and the space not known lost.
  call::Reply call(const std::string& space, const std::string& service, const std::string& operation,
                   std::string payload, std::chrono::milliseconds deadline, const std::string& caller);
  bool oneway(const std::string& space, const std::string& service, const std::string& operation,
              std::string payload, const std::string& caller);

  void read_replies(eprosima::fastdds::dds::DataReader* reader);
  // The calls waiting for a reply from `space` fail (PROVIDER_GONE): its bridge left or was lost.
  void fail_pending(const std::string& space);
  // The link is closing (the gate closed): callers waiting for a match are woken, those waiting
  // for a reply get UNAVAILABLE "bridge stopping".
  void close();

 private:
  // A call waiting for its reply.
  struct Pending {
    std::string space;
    std::promise<call::Reply> promise;
  };
  // Follows a request writer's matched readers: wakes the callers waiting for the first one
  // (wait_matched), and notices the writer losing its last: the target space's bridge left.
  class RequestWriterListener : public eprosima::fastdds::dds::DataWriterListener {
   public:
    RequestWriterListener(DdsCalls& calls, std::string space) : calls_(calls), space_(std::move(space)) {}
    void on_publication_matched(eprosima::fastdds::dds::DataWriter*,
                                const eprosima::fastdds::dds::PublicationMatchedStatus& status) override;
    // Waits until the writer has a matched reader, or `until`, or the link closes (false). Blocks:
    // never on a DDS listener thread (the match it waits for would be reported on such a thread).
    bool wait_matched(Clock::time_point until);
    // Wakes the callers in wait_matched() (the link is closing).
    void wake();

   private:
    DdsCalls& calls_;
    const std::string space_;
    std::mutex mutex_;
    std::condition_variable matched_changed_;
    int32_t matched_ = 0;  // readers matched now
  };
  struct RequestRoute {
    eprosima::fastdds::dds::DataWriter* writer = nullptr;
    RequestWriterListener* listener = nullptr;  // owned by writer_listeners_
  };

  RequestRoute request_writer(const std::string& space);  // caller holds mutex_
  std::string next_request_id();

  const DdsOptions& options_;
  LinkParticipant& participant_;
  CallGate& gate_;
  RpcRegistrations& registrations_;
  DdsIdentities& identities_;
  const std::string reply_name_;  // replies to this space's calls
  // Part of every request id: ids stay unique across restarts of this bridge, so a replier that
  // remembers an earlier run's id never takes a new call for a duplicate.
  const std::string run_;
  eprosima::fastdds::dds::DataReader* reply_reader_ = nullptr;

  std::mutex mutex_;  // guards the maps below and the writers' creation
  std::map<std::string, RequestRoute> request_writers_;  // by target space
  std::vector<std::unique_ptr<RequestWriterListener>> writer_listeners_;
  std::map<std::string, std::shared_ptr<Pending>> pending_;  // by request id
  std::atomic<uint64_t> next_id_{1};
};

}  // namespace urs::bridge
