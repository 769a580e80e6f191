#pragma once
// DdsServed (internal to urs::bridge): the serving side of the DdsLink. This space's request
// reader hands each request to the call handler once (a second delivery of an executed request,
// or one past its deadline, is dropped), the responder writes the reply on a reply writer per
// calling space and keeps it registered until the caller is done with it or its deadline passed.
// A reply given on one of the link's listener threads is written by the replier thread instead
// (see DdsLink::CallHandler).
//
// Threads: read_requests() on DDS listener threads, inside an OnListener; the responders from any
// thread; stop() from the link's destructor (replies queued then are dropped). Its locks are never
// held while the handler runs or Fast DDS writes a reply.

#include <chrono>
#include <deque>
#include <fastdds/dds/common/InstanceHandle.hpp>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <utility>

#include "call_gate.hpp"
#include "dds_identity.hpp"
#include "dds_participant.hpp"
#include "rpc_registrations.hpp"
#include "urs/agent/agent.hpp"
#include "urs/federation/dds_link.hpp"

namespace urs::federation {

class DdsServed {
 public:
  using Clock = std::chrono::steady_clock;

  // Marks this thread as running one of the link's reader listeners while it lives (the link's
  // on_data_available holds one): a reply given there goes through the replier thread.
  class OnListener {
   public:
    OnListener() : outer_(on_listener_thread) { on_listener_thread = true; }
    ~OnListener() { on_listener_thread = outer_; }
    OnListener(const OnListener&) = delete;
    OnListener& operator=(const OnListener&) = delete;

   private:
    bool outer_;
  };

  // `identities` says who wrote each request (the caller of the call, and where its reply goes).
  DdsServed(const DdsOptions& options, LinkParticipant& participant, CallGate& gate, RpcRegistrations& registrations,
            DdsIdentities& identities, DdsLink::CallHandler on_call);
  DdsServed(const DdsServed&) = delete;
  DdsServed& operator=(const DdsServed&) = delete;

  // `self` shares the link's ownership (the responders hold it weakly: a reply after the link is
  // gone is dropped). Creates the request reader with `listener` (which hands its data to
  // read_requests()); throws std::runtime_error if DDS refuses.
  void open(std::weak_ptr<DdsServed> self, eprosima::fastdds::dds::DataReaderListener* listener);
  const std::string& request_name() const { return request_name_; }  // the request reader's topic

  void read_requests(eprosima::fastdds::dds::DataReader* reader);
  // The payload bytes of the requests read from each calling space and of the replies written to
  // it (at most DdsLink::kMaxCountedSpaces spaces), by the caller's space as the link took it.
  std::map<std::string, SpaceServed> space_served() const;
  // Stops the replier thread: a reply it would write now is refused (the gate is closed), those
  // queued are dropped.
  void stop() { replier_.stop(); }

 private:
  static thread_local bool on_listener_thread;

  bool first_delivery(const std::string& id, Clock::time_point until);
  void caller_done(const eprosima::fastdds::dds::InstanceHandle_t& instance);
  void serve(const eprosima::fastdds::dds::InstanceHandle_t& instance, const std::string& id, Clock::time_point until);
  call::Responder responder_for(const std::string& space, const std::string& id, Clock::time_point until);
  void reply_if_open(const std::string& space, const std::string& id, const call::Reply& reply,
                     Clock::time_point until);
  void send_reply(const std::string& space, const std::string& id, const call::Reply& result, Clock::time_point until);
  eprosima::fastdds::dds::DataWriter* reply_writer(const std::string& space);  // caller holds writers_mutex_

  const DdsOptions& options_;
  LinkParticipant& participant_;
  CallGate& gate_;
  RpcRegistrations& registrations_;
  DdsIdentities& identities_;
  const DdsLink::CallHandler on_call_;
  const std::string request_name_;  // this space's requests
  std::weak_ptr<DdsServed> self_;
  eprosima::fastdds::dds::DataReader* request_reader_ = nullptr;
  // Writes the replies given on the link's listener threads (responder_for).
  agent::WorkerPool replier_{1};

  // Counts `request` or reply bytes of `space` (space_served()).
  void count_bytes(const std::string& space, std::size_t bytes, bool request);
  mutable std::mutex counts_mutex_;  // guards counts_; taken with no other lock held
  std::map<std::string, SpaceServed> counts_;

  std::mutex writers_mutex_;                                                  // guards reply_writers_
  std::map<std::string, eprosima::fastdds::dds::DataWriter*> reply_writers_;  // by caller space
  // Requests this replier executed, against a second delivery (transient-local history sent again
  // to a reader that matched again): id -> until when it could arrive again.
  std::mutex executed_mutex_;  // guards the three below
  std::map<std::string, Clock::time_point> executed_;
  std::deque<std::pair<Clock::time_point, std::string>> executed_order_;
  // Requests being served, by their instance on the request reader: when the caller unregisters
  // one (it has the reply, or gave up), its reply is retired at once.
  std::map<eprosima::fastdds::dds::InstanceHandle_t, std::pair<std::string, Clock::time_point>> serving_;
};

}  // namespace urs::federation
