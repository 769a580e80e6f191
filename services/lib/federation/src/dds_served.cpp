#include "dds_served.hpp"

#include <spdlog/spdlog.h>

#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/publisher/Publisher.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>
#include <fastdds/dds/subscriber/Subscriber.hpp>
#include <fastdds/dds/topic/Topic.hpp>
#include <stdexcept>

#include "Federation.h"
#include "dds_participant.hpp"
#include "dds_rpc.hpp"
#include "urs/util/trace.hpp"

namespace urs::federation {

namespace fdds = eprosima::fastdds::dds;
using dds_rpc::bytes_of;
using dds_rpc::kDefaultDeadline;
using dds_rpc::text_of;

namespace {

// Executed request ids remembered at most (the oldest forgotten first).
constexpr std::size_t kRememberedRequests = 65536;

// True if `request` was sent longer ago than its deadline (by its writer's clock, which the
// sites keep in step): its caller has given up, whoever delivers it now.
bool stale(const dds::CallRequest& request, const fdds::SampleInfo& info) {
  const auto& sent = info.source_timestamp;
  if (sent == eprosima::fastrtps::rtps::c_RTPSTimeInvalid || sent.seconds() <= 0) return false;
  const auto sent_at =
      std::chrono::system_clock::time_point(std::chrono::duration_cast<std::chrono::system_clock::duration>(
          std::chrono::seconds(sent.seconds()) + std::chrono::nanoseconds(sent.nanosec())));
  const auto deadline =
      request.deadline_ms() == 0 ? kDefaultDeadline : std::chrono::milliseconds(request.deadline_ms());
  return std::chrono::system_clock::now() - sent_at > deadline;
}

}  // namespace

thread_local bool DdsServed::on_listener_thread = false;

DdsServed::DdsServed(const DdsOptions& options, LinkParticipant& participant, CallGate& gate,
                     RpcRegistrations& registrations, DdsIdentities& identities, DdsLink::CallHandler on_call)
    : options_(options),
      participant_(participant),
      gate_(gate),
      registrations_(registrations),
      identities_(identities),
      on_call_(std::move(on_call)),
      request_name_(dds_rpc::request_topic(options.space)) {}

void DdsServed::open(std::weak_ptr<DdsServed> self, fdds::DataReaderListener* listener) {
  self_ = std::move(self);
  request_reader_ = participant_.subscriber()->create_datareader(
      participant_.topic(request_name_, participant_.request_type), dds_rpc::rpc_reader_qos(), listener);
  if (!request_reader_) throw std::runtime_error("DDS: cannot create the call endpoints");
}

fdds::DataWriter* DdsServed::reply_writer(const std::string& space) {
  auto it = reply_writers_.find(space);
  if (it != reply_writers_.end()) return it->second;
  fdds::DataWriter* writer = participant_.publisher()->create_datawriter(
      participant_.topic(dds_rpc::reply_topic(space), participant_.reply_type), dds_rpc::rpc_writer_qos());
  if (writer == nullptr) throw std::runtime_error("DDS: cannot write replies to space " + space);
  reply_writers_[space] = writer;
  return writer;
}

// True the first time `id` arrives (within `until`), false for a second delivery.
bool DdsServed::first_delivery(const std::string& id, Clock::time_point until) {
  std::lock_guard lock(executed_mutex_);
  const auto now = Clock::now();
  while (!executed_order_.empty() &&
         (executed_order_.front().first <= now || executed_order_.size() >= kRememberedRequests)) {
    auto it = executed_.find(executed_order_.front().second);
    if (it != executed_.end() && it->second == executed_order_.front().first) executed_.erase(it);
    executed_order_.pop_front();
  }
  if (!executed_.emplace(id, until).second) return false;
  executed_order_.emplace_back(until, id);
  return true;
}

// The caller of the request on `instance` no longer waits for it: its reply is retired.
void DdsServed::caller_done(const fdds::InstanceHandle_t& instance) {
  std::string id;
  {
    std::lock_guard lock(executed_mutex_);
    auto it = serving_.find(instance);
    if (it == serving_.end()) return;
    id = it->second.first;
    serving_.erase(it);
  }
  registrations_.retire_reply(id);
}

void DdsServed::serve(const fdds::InstanceHandle_t& instance, const std::string& id, Clock::time_point until) {
  std::lock_guard lock(executed_mutex_);
  if (serving_.size() >= static_cast<std::size_t>(dds_rpc::kRpcInFlight)) {
    const auto now = Clock::now();
    for (auto it = serving_.begin(); it != serving_.end();) it = it->second.second <= now ? serving_.erase(it) : ++it;
  }
  serving_[instance] = {id, until};
}

std::map<std::string, SpaceServed> DdsServed::space_served() const {
  std::lock_guard lock(counts_mutex_);
  return counts_;
}

void DdsServed::count_bytes(const std::string& space, std::size_t bytes, bool request) {
  std::lock_guard lock(counts_mutex_);
  auto it = counts_.find(space);
  if (it == counts_.end()) {
    if (counts_.size() >= DdsLink::kMaxCountedSpaces) return;
    it = counts_.emplace(space, SpaceServed{}).first;
  }
  (request ? it->second.request_bytes : it->second.reply_bytes) += bytes;
}

void DdsServed::read_requests(fdds::DataReader* reader) {
  dds::CallRequest sample;
  fdds::SampleInfo info;
  while (reader->take_next_sample(&sample, &info) == ReturnCode_t::RETCODE_OK) {
    if (!info.valid_data) {  // a request its caller no longer waits for
      caller_done(info.instance_handle);
      continue;
    }
    if (stale(sample, info)) {
      spdlog::info("dds: request {} from space {} arrived after its deadline; not executed", sample.request_id(),
                   sample.caller_space());
      continue;
    }
    const std::string& id = sample.request_id();
    const auto arrived = Clock::now();
    const auto until =
        arrived + (sample.deadline_ms() == 0 ? kDefaultDeadline : std::chrono::milliseconds(sample.deadline_ms()));
    if (!first_delivery(id, until)) {
      spdlog::debug("dds: request {} delivered again; executed once already", id);
      continue;
    }
    call::Request request;
    request.service = sample.service();
    request.operation = sample.operation();
    request.payload = text_of(sample.payload());
    if (sample.deadline_ms() != 0) request.deadline = arrived + std::chrono::milliseconds(sample.deadline_ms());
    // On a secured link, the space the writer's participant proved, whatever the request declares;
    // the name inside it is the one the request carries: that space speaks for its own callers.
    request.caller = identities_.caller(info.publication_handle, sample.caller_space());
    count_bytes(request.caller.space, request.payload.size(), true);
    request.oneway = sample.no_reply();
    // The caller's trace, if it sent a valid one (parse() refuses a long value before copying it).
    if (const auto trace = util::TraceContext::parse(sample.traceparent())) request.traceparent = trace->traceparent();
    call::Responder responder;
    if (!request.oneway) {
      serve(info.instance_handle, id, until);
      responder = responder_for(request.caller.space, id, until);
    }
    if (!sample.caller_name().empty()) {
      const std::string problem = caller_name_problem(sample.caller_name());
      if (!problem.empty()) {
        spdlog::warn("dds: request {} from space {}: its caller's name {}; not executed", id, request.caller.space,
                     problem);
        responder.reply(
            call::Reply::error(call::Status::BAD_ARGUMENTS, "the caller's name (CallRequest.caller_name) " + problem));
        continue;
      }
      request.caller.name = sample.caller_name();
    }
    on_call_(std::move(request), std::move(responder));
  }
}

// Answers a call of `space` through the link while it exists: off this link's listener threads
// at once, on one of them through the replier thread (see CallHandler).
call::Responder DdsServed::responder_for(const std::string& space, const std::string& id, Clock::time_point until) {
  std::weak_ptr<DdsServed> link = self_;
  return call::Responder::from_callback([link, space, id, until](call::Reply reply) {
    auto d = link.lock();
    if (!d) return;  // the link is gone: nobody to write the reply
    if (!on_listener_thread) {
      d->reply_if_open(space, id, reply, until);
      return;
    }
    d->replier_.post([link, space, id, reply = std::move(reply), until](bool cancelled) {
      if (cancelled) return;  // the link is stopping
      if (auto d = link.lock()) d->reply_if_open(space, id, reply, until);
    });
  });
}

// The reply is written unless the link is stopping (its writers may be deleted then).
void DdsServed::reply_if_open(const std::string& space, const std::string& id, const call::Reply& reply,
                              Clock::time_point until) {
  const CallGate::InProgress in_progress(gate_);
  if (in_progress.admitted()) send_reply(space, id, reply, until);
}

void DdsServed::send_reply(const std::string& space, const std::string& id, const call::Reply& result,
                           Clock::time_point until) {
  // Written at once, matched reader or not: the caller's reply reader, if it matches this
  // writer later, still gets the reply while it is registered (until the caller's deadline).
  fdds::DataWriter* writer = nullptr;
  try {
    std::lock_guard lock(writers_mutex_);
    writer = reply_writer(space);
  } catch (const std::exception& e) {
    spdlog::error("dds: reply to {} for {}: {}", space, id, e.what());
    return;
  }
  dds::CallReply reply;
  reply.request_id(id);
  reply.status(call::status_number(result.status));
  reply.message(result.message);
  reply.exception_type(result.exception_type);
  reply.payload(bytes_of(result.payload));
  if (!writer->write(&reply)) {
    spdlog::warn("dds: the reply to {} could not be written", id);
    return;
  }
  count_bytes(space, result.payload.size(), false);
  // Registered once written: a caller done with it during the write (in this process, its reply
  // listener runs inside the write) must not unregister it on this writer then, which Fast DDS 2.9
  // does not take while the write delivers; such a reply is retired at `until`.
  registrations_.retire_later(writer, id, true, until);
}

}  // namespace urs::federation
