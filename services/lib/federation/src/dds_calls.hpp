#pragma once
// DdsCalls (internal to urs::bridge): the calling side of the DdsLink. A request writer per target
// space (made at its first call, with a listener that follows its matched readers), the calls
// waiting for their replies by request id, this space's reply reader; call(), call_async(),
// oneway() and oneway_async() as DdsLink's, after the link admitted them (CallGate) and checked
// the space's liveliness.
//
// Every call waits for its reply the same way: it is registered with a completion (`Done`) that
// the reply (read_replies), its space's bridge leaving (fail_pending), the link closing (close) or
// its deadline (the link's call thread) runs, whichever comes first; call() is call_async()'s wait.
// Once a call ended its request is unregistered (RpcRegistrations::retire) by the call thread,
// never on the thread that ended it (a listener's, maybe inside the replier's write in this
// process), and the requests of the calls ended within kRetireDelay together: one wake-up of the
// call thread for many calls, none on the caller's way back.
//
// Threads: call() and oneway() block (a first match; call(), then the reply): never on a DDS
// listener or Planet I/O thread. call_async() and oneway_async() never block: they refuse a space
// whose writer is not matched yet. read_replies() and fail_pending() on DDS listener threads;
// close() from the link's destructor. Two locks: one for the writers (Fast DDS is called under it,
// never taken on a listener thread), one for the pending calls and the call thread's work (taken
// on listener threads, never held while a completion runs or Fast DDS is called).

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <fastdds/dds/publisher/DataWriterListener.hpp>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "call_gate.hpp"
#include "dds_identity.hpp"
#include "dds_participant.hpp"
#include "rpc_registrations.hpp"
#include "urs/federation/dds_link.hpp"

namespace urs::federation {

class DdsCalls {
 public:
  using Clock = std::chrono::steady_clock;
  using Done = std::function<void(call::Reply)>;

  // `identities` says which space wrote each reply: on a secured link only the called space's are taken.
  DdsCalls(const DdsOptions& options, LinkParticipant& participant, CallGate& gate, RpcRegistrations& registrations,
           DdsIdentities& identities);
  ~DdsCalls();  // close()
  DdsCalls(const DdsCalls&) = delete;
  DdsCalls& operator=(const DdsCalls&) = delete;

  // Creates the reply reader with `listener` (which hands its data to read_replies()); throws
  // std::runtime_error if DDS refuses.
  void open(eprosima::fastdds::dds::DataReaderListener* listener);
  const std::string& reply_name() const { return reply_name_; }  // the reply reader's topic

  // DdsLink::call(), call_async(), oneway() and oneway_async(), once admitted and the space not
  // known lost.
  call::Reply call(const std::string& space, const std::string& service, const std::string& operation,
                   std::string payload, std::chrono::milliseconds deadline, const std::string& caller);
  bool call_async(const std::string& space, const std::string& service, const std::string& operation,
                  std::string&& payload, std::chrono::milliseconds deadline, const std::string& caller, Done done);
  bool oneway(const std::string& space, const std::string& service, const std::string& operation, std::string payload,
              const std::string& caller);
  std::optional<bool> oneway_async(const std::string& space, const std::string& service, const std::string& operation,
                                   std::string&& payload, const std::string& caller);

  void read_replies(eprosima::fastdds::dds::DataReader* reader);
  // What the calls to each space met (DdsLink::space_calls()).
  std::map<std::string, SpaceCalls> space_calls() const;
  // Counts a failure the link gave a call to `space` (`reply` is not OK). Any thread, no lock held.
  void count_failure(const std::string& space, const call::Reply& reply);

  // The calls waiting for a reply from `space` fail (PROVIDER_GONE): its bridge left or was lost.
  void fail_pending(const std::string& space);
  // The link is closing (the gate closed): callers waiting for a match are woken, those waiting
  // for a reply get UNAVAILABLE "bridge stopping", and the call thread ends. Idempotent.
  void close();

 private:
  // A call waiting for its reply.
  struct Pending {
    std::string id;  // its request's
    std::string space;
    std::string service;
    std::string operation;
    eprosima::fastdds::dds::DataWriter* writer = nullptr;  // its request's
    Clock::time_point started;                             // its request about to be written
    Clock::time_point until;                               // its deadline
    std::chrono::milliseconds deadline{0};                 // as the caller gave it, for the message
    Done done;
    // Its request is retired once both have happened (the second one retires it): written, and
    // the call ended. Retired before it is written, it would stay registered.
    std::atomic<int> steps{0};
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
    bool matched();  // has a matched reader now
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

  RequestRoute request_writer(const std::string& space);  // caller holds writers_mutex_
  // The writer to `space` if it exists and is matched: a call to it can start without waiting.
  std::optional<RequestRoute> matched_writer(const std::string& space);
  std::string next_request_id();
  // Registers the call, ending at `until` (`deadline` after the caller made it), and writes its
  // request on `writer`; `done` gets its outcome (maybe before this returns, on this thread, when
  // the link is closing or the request cannot be written). Once written and ended, the call
  // thread retires its request.
  void start(const std::string& space, eprosima::fastdds::dds::DataWriter* writer, const std::string& service,
             const std::string& operation, std::string&& payload, Clock::time_point until,
             std::chrono::milliseconds deadline, const std::string& caller, Done done);
  bool send_oneway(const std::string& space, eprosima::fastdds::dds::DataWriter* writer, const std::string& service,
                   const std::string& operation, std::string&& payload, const std::string& caller);
  // Counts `bytes` of request payload written to `space` (SpaceCalls::request_bytes).
  void count_request_bytes(const std::string& space, std::size_t bytes);
  // The pending call `id`, taken away (its deadline too): nobody else ends it. Caller holds mutex_.
  std::shared_ptr<Pending> take(const std::string& id);
  // Runs the call's completion with `reply` and counts its end towards retiring its request.
  void end(Pending& call, call::Reply reply);
  void step(Pending& call);  // written or ended: the second hands its request to the call thread
  // The call thread: ends the calls whose deadline passed and retires the requests of those that ended.
  void run();
  // The counts of `space`, made if there is room (null if not). Caller holds counts_mutex_.
  SpaceCalls* counts_of(const std::string& space);

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

  // Guards the request writers and their creation. Never taken on a DDS listener thread, so Fast
  // DDS may be called under it (creating a writer takes Fast DDS's locks of the readers it pairs
  // with, which a listener holds while it runs).
  std::mutex writers_mutex_;
  std::map<std::string, RequestRoute> request_writers_;  // by target space
  std::vector<std::unique_ptr<RequestWriterListener>> writer_listeners_;
  // Guards the calls and the call thread's work below. Taken on DDS listener threads (replies,
  // lost bridges), so never held while Fast DDS is called.
  std::mutex mutex_;
  std::map<std::string, std::shared_ptr<Pending>> pending_;        // by request id
  std::set<std::pair<Clock::time_point, std::string>> deadlines_;  // of pending_, earliest first
  // Requests of ended calls to unregister (writer, id), by the call thread; after close(), none
  // (the writers go with the link).
  std::vector<std::pair<eprosima::fastdds::dds::DataWriter*, std::string>> retiring_;
  Clock::time_point retire_due_ = Clock::time_point::max();  // when retiring_ is unregistered
  // When the call thread wakes next (min(): it is awake). It is woken only for a deadline or a
  // retirement due before that, not once per call: a call's own deadline is rarely the earliest
  // and the ended calls' requests are unregistered together, kRetireDelay after the first.
  Clock::time_point next_wake_ = Clock::time_point::min();
  std::condition_variable wake_;  // the call thread: an earlier deadline, retirements due earlier, closing
  bool closed_ = false;
  std::atomic<uint64_t> next_id_{1};
  // What the calls met, by space (at most DdsLink::kMaxCountedSpaces). Its own lock, taken with no
  // other held: replies are counted on listener threads, the counts read by a metrics scrape.
  mutable std::mutex counts_mutex_;
  std::map<std::string, SpaceCalls> counts_;
  std::thread thread_;  // the call thread; last: started once the rest exists
};

}  // namespace urs::federation
