#include "dds_calls.hpp"

#include <spdlog/spdlog.h>

#include <cstdio>
#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/publisher/Publisher.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>
#include <fastdds/dds/subscriber/Subscriber.hpp>
#include <fastdds/dds/topic/Topic.hpp>
#include <future>
#include <random>
#include <stdexcept>

#include "Federation.h"
#include "dds_participant.hpp"
#include "dds_rpc.hpp"
#include "urs/util/trace.hpp"

namespace urs::federation {

namespace fdds = eprosima::fastdds::dds;
using dds_rpc::bytes_of;
using dds_rpc::text_of;

namespace {

// How long a call to a space waits for its request writer to match a bridge of that space
// (discovery, for the first call to it). The wait is on a condition variable the writer's
// matched-status listener signals, on a DDS listener thread: so call() and oneway() never run on
// one (nor on a Planet client's I/O thread, which they would hold up). The bridge calls them from
// its agent host's workers (the bridge's ForwardingAgent::invoke, when call_async() refused a space not
// matched yet) and CORBA's threads; a call forwarded from a Planet or DDS thread goes through
// call_async() and oneway_async(), which never wait.
constexpr std::chrono::milliseconds kMatchWait{2000};
// How long the request of an ended asynchronous call may stay registered, so that the call thread
// unregisters the requests of many calls at one wake-up. A bridge of the called space matching
// within that time could still take the request, and find its caller gone.
constexpr std::chrono::milliseconds kRetireDelay{10};

}  // namespace

void DdsCalls::RequestWriterListener::on_publication_matched(fdds::DataWriter*,
                                                             const fdds::PublicationMatchedStatus& status) {
  {
    // Never held while DDS is called: this may run holding DDS's own locks.
    std::lock_guard lock(mutex_);
    matched_ = status.current_count;
  }
  matched_changed_.notify_all();
  if (status.current_count == 0 && status.current_count_change < 0) calls_.fail_pending(space_);
}

bool DdsCalls::RequestWriterListener::wait_matched(Clock::time_point until) {
  std::unique_lock lock(mutex_);
  matched_changed_.wait_until(lock, until, [this] { return matched_ > 0 || calls_.gate_.closing(); });
  return matched_ > 0 && !calls_.gate_.closing();
}

bool DdsCalls::RequestWriterListener::matched() {
  std::lock_guard lock(mutex_);
  return matched_ > 0;
}

void DdsCalls::RequestWriterListener::wake() {
  { std::lock_guard lock(mutex_); }
  matched_changed_.notify_all();
}

DdsCalls::DdsCalls(const DdsOptions& options, LinkParticipant& participant, CallGate& gate,
                   RpcRegistrations& registrations, DdsIdentities& identities)
    : options_(options),
      participant_(participant),
      gate_(gate),
      registrations_(registrations),
      identities_(identities),
      reply_name_(dds_rpc::reply_topic(options.space)),
      run_([] {
        std::random_device random;
        char text[20];
        std::snprintf(text, sizeof text, "%08x%08x", random(), random());
        return std::string(text);
      }()),
      thread_([this] { run(); }) {}

DdsCalls::~DdsCalls() { close(); }

void DdsCalls::open(fdds::DataReaderListener* listener) {
  reply_reader_ = participant_.subscriber()->create_datareader(participant_.topic(reply_name_, participant_.reply_type),
                                                               dds_rpc::rpc_reader_qos(), listener);
  if (!reply_reader_) throw std::runtime_error("DDS: cannot create the call endpoints");
}

DdsCalls::RequestRoute DdsCalls::request_writer(const std::string& space) {
  auto it = request_writers_.find(space);
  if (it != request_writers_.end()) return it->second;
  // The listener is the writer's from its creation on: no match goes unreported.
  auto listener = std::make_unique<RequestWriterListener>(*this, space);
  fdds::DataWriter* writer = participant_.publisher()->create_datawriter(
      participant_.topic(dds_rpc::request_topic(space), participant_.request_type), dds_rpc::rpc_writer_qos(),
      listener.get());
  if (writer == nullptr) throw std::runtime_error("DDS: cannot write requests to space " + space);
  RequestRoute route{writer, listener.get()};
  writer_listeners_.push_back(std::move(listener));
  request_writers_[space] = route;
  return route;
}

std::string DdsCalls::next_request_id() {
  return options_.space + "/" + options_.bridge + "/" + run_ + "/" + std::to_string(next_id_++);
}

std::optional<DdsCalls::RequestRoute> DdsCalls::matched_writer(const std::string& space) {
  RequestRoute route;
  {
    std::lock_guard lock(writers_mutex_);
    auto it = request_writers_.find(space);
    if (it == request_writers_.end()) return std::nullopt;
    route = it->second;
  }
  if (!route.listener->matched()) return std::nullopt;
  return route;
}

std::shared_ptr<DdsCalls::Pending> DdsCalls::take(const std::string& id) {
  auto it = pending_.find(id);
  if (it == pending_.end()) return nullptr;
  std::shared_ptr<Pending> call = std::move(it->second);
  pending_.erase(it);
  deadlines_.erase({call->until, id});
  return call;
}

void DdsCalls::end(Pending& call, call::Reply reply) {
  call.done(std::move(reply));
  step(call);
}

void DdsCalls::step(Pending& call) {
  if (++call.steps < 2) return;
  std::lock_guard lock(mutex_);
  // Closed: the link is going, its writers with it (and with them their instances); this may be
  // a listener's thread inside the replier's write, where Fast DDS 2.9 would deadlock on an
  // unregistration.
  if (closed_) return;
  retiring_.emplace_back(call.writer, call.id);
  if (retiring_.size() == 1) {
    retire_due_ = Clock::now() + kRetireDelay;
    if (retire_due_ < next_wake_) wake_.notify_one();
  }
}

SpaceCalls* DdsCalls::counts_of(const std::string& space) {
  auto it = counts_.find(space);
  if (it != counts_.end()) return &it->second;
  if (counts_.size() >= DdsLink::kMaxCountedSpaces) return nullptr;
  return &counts_[space];
}

std::map<std::string, SpaceCalls> DdsCalls::space_calls() const {
  std::lock_guard lock(counts_mutex_);
  return counts_;
}

void DdsCalls::count_failure(const std::string& space, const call::Reply& reply) {
  std::lock_guard lock(counts_mutex_);
  SpaceCalls* counts = counts_of(space);
  if (counts == nullptr) return;
  ++counts->failures[reply.status];
  counts->last_failure_at = std::chrono::system_clock::now();
}

void DdsCalls::count_request_bytes(const std::string& space, std::size_t bytes) {
  std::lock_guard lock(counts_mutex_);
  if (SpaceCalls* counts = counts_of(space)) counts->request_bytes += bytes;
}

void DdsCalls::fail_pending(const std::string& space) {
  std::vector<std::shared_ptr<Pending>> failed;
  {
    std::lock_guard lock(mutex_);
    for (auto it = pending_.begin(); it != pending_.end();) {
      if (it->second->space == space) {
        deadlines_.erase({it->second->until, it->first});
        failed.push_back(std::move(it->second));
        it = pending_.erase(it);
      } else {
        ++it;
      }
    }
  }
  if (failed.empty()) return;
  const call::Reply gone =
      call::Reply::error(call::Status::PROVIDER_GONE, "the bridge of space " + space + " left during the call");
  for (auto& call : failed) {
    count_failure(space, gone);
    end(*call, gone);
  }
}

void DdsCalls::close() {
  std::vector<std::shared_ptr<Pending>> left;
  {
    std::lock_guard lock(mutex_);  // a call registers its pending reply under it, closing or not
    if (closed_) return;
    closed_ = true;
    for (auto& [id, call] : pending_) left.push_back(std::move(call));
    pending_.clear();
    deadlines_.clear();
    wake_.notify_one();
  }
  {
    std::lock_guard lock(writers_mutex_);
    for (auto& listener : writer_listeners_) listener->wake();
  }
  thread_.join();
  std::vector<std::pair<fdds::DataWriter*, std::string>> retiring;
  {
    std::lock_guard lock(mutex_);
    retiring.swap(retiring_);
  }
  for (const auto& [writer, id] : retiring) RpcRegistrations::retire(writer, id, false);
  for (auto& call : left) end(*call, call::Reply::error(call::Status::UNAVAILABLE, "bridge stopping"));
}

void DdsCalls::run() {
  std::unique_lock lock(mutex_);
  while (!closed_) {
    std::vector<std::shared_ptr<Pending>> expired;
    const auto now = Clock::now();
    while (!deadlines_.empty() && deadlines_.begin()->first <= now) expired.push_back(take(deadlines_.begin()->second));
    std::vector<std::pair<fdds::DataWriter*, std::string>> retiring;
    if (retire_due_ <= now) {
      retiring.swap(retiring_);
      retire_due_ = Clock::time_point::max();
    }
    if (expired.empty() && retiring.empty()) {
      next_wake_ = std::min(retire_due_, deadlines_.empty() ? Clock::time_point::max() : deadlines_.begin()->first);
      if (next_wake_ == Clock::time_point::max()) {
        wake_.wait(lock);
      } else {
        wake_.wait_until(lock, next_wake_);
      }
      next_wake_ = Clock::time_point::min();
      continue;
    }
    lock.unlock();
    for (auto& call : expired) {
      call::Reply late =
          call::Reply::error(call::Status::DEADLINE_EXCEEDED, "no reply from space " + call->space + " for " +
                                                                  call->service + "." + call->operation + " within " +
                                                                  std::to_string(call->deadline.count()) + " ms");
      count_failure(call->space, late);
      end(*call, std::move(late));
    }
    for (const auto& [writer, id] : retiring) RpcRegistrations::retire(writer, id, false);
    lock.lock();
  }
}

void DdsCalls::start(const std::string& space, fdds::DataWriter* writer, const std::string& service,
                     const std::string& operation, std::string&& payload, Clock::time_point until,
                     std::chrono::milliseconds deadline, const std::string& caller, Done done) {
  auto call = std::make_shared<Pending>();
  call->id = next_request_id();
  call->space = space;
  call->service = service;
  call->operation = operation;
  call->writer = writer;
  call->until = until;
  call->deadline = deadline;
  call->done = std::move(done);
  bool closing = false;
  {
    std::lock_guard lock(mutex_);  // close() takes the calls registered before it
    closing = closed_ || gate_.closing();
    if (!closing) {
      pending_[call->id] = call;
      const auto deadline_at = deadlines_.emplace(call->until, call->id).first;
      if (deadline_at->first < next_wake_) wake_.notify_one();  // before the call thread would wake
    }
  }
  if (closing) {
    call->done(call::Reply::error(call::Status::UNAVAILABLE, "bridge stopping"));
    return;
  }
  dds::CallRequest request;
  request.request_id(call->id);
  request.caller_space(options_.space);
  request.service(service);
  request.operation(operation);
  request.deadline_ms(static_cast<uint32_t>(
      std::max<int64_t>(1, std::chrono::duration_cast<std::chrono::milliseconds>(call->until - Clock::now()).count())));
  request.no_reply(false);
  request.payload(bytes_of(payload));
  request.caller_name(caller);
  request.traceparent(util::outgoing_trace().traceparent());  // the caller's trace, continued there
  spdlog::debug("dds: request {} to space {}: {}.{}", call->id, space, service, operation);
  call->started = Clock::now();  // before the write: a reply may be read before it returns
  if (writer->write(&request)) {
    count_request_bytes(space, request.payload().size());
    step(*call);
    return;
  }
  std::shared_ptr<Pending> failed;
  {
    std::lock_guard lock(mutex_);
    failed = take(call->id);
  }
  // Nothing to retire: it was never registered.
  if (failed) {
    call::Reply unwritten =
        call::Reply::error(call::Status::UNAVAILABLE, "the request to space " + space + " could not be written");
    count_failure(space, unwritten);
    failed->done(std::move(unwritten));
  }
}

call::Reply DdsCalls::call(const std::string& space, const std::string& service, const std::string& operation,
                           std::string payload, std::chrono::milliseconds deadline, const std::string& caller) {
  const auto until = Clock::now() + deadline;
  {
    std::lock_guard lock(mutex_);
    if (closed_ || gate_.closing()) return call::Reply::error(call::Status::UNAVAILABLE, "bridge stopping");
  }
  RequestRoute route;
  try {
    std::lock_guard lock(writers_mutex_);
    route = request_writer(space);
  } catch (const std::exception& e) {
    // On a secured link, the access control refused the writer.
    call::Reply refused =
        options_.security.enabled()
            ? call::Reply::error(call::Status::PERMISSION_DENIED,
                                 "the permissions of space " + options_.space + " do not grant calls to space " + space)
            : call::Reply::error(call::Status::UNAVAILABLE, e.what());
    count_failure(space, refused);
    return refused;
  }
  // A writer made for this call waits for discovery; a known space's is matched already.
  if (!route.listener->wait_matched(std::min(until, Clock::now() + kMatchWait))) {
    if (gate_.closing()) return call::Reply::error(call::Status::UNAVAILABLE, "bridge stopping");
    call::Reply unmatched = call::Reply::error(
        call::Status::UNAVAILABLE, "space " + space + " is not reachable over DDS (no bridge of it matched)");
    count_failure(space, unmatched);
    return unmatched;
  }
  // The completion may outlive this frame by a moment (it runs on to its end after waking it).
  auto answer = std::make_shared<std::promise<call::Reply>>();
  auto reply = answer->get_future();
  start(space, route.writer, service, operation, std::move(payload), until, deadline, caller,
        [answer](call::Reply result) { answer->set_value(std::move(result)); });
  return reply.get();
}

bool DdsCalls::call_async(const std::string& space, const std::string& service, const std::string& operation,
                          std::string&& payload, std::chrono::milliseconds deadline, const std::string& caller,
                          Done done) {
  const std::optional<RequestRoute> route = matched_writer(space);
  if (!route) return false;
  start(space, route->writer, service, operation, std::move(payload), Clock::now() + deadline, deadline, caller,
        std::move(done));
  return true;
}

bool DdsCalls::oneway(const std::string& space, const std::string& service, const std::string& operation,
                      std::string payload, const std::string& caller) {
  if (gate_.closing()) return false;
  RequestRoute route;
  try {
    std::lock_guard lock(writers_mutex_);
    route = request_writer(space);
  } catch (const std::exception&) {
    return false;
  }
  if (!route.listener->wait_matched(Clock::now() + kMatchWait)) return false;
  return send_oneway(space, route.writer, service, operation, std::move(payload), caller);
}

std::optional<bool> DdsCalls::oneway_async(const std::string& space, const std::string& service,
                                           const std::string& operation, std::string&& payload,
                                           const std::string& caller) {
  const std::optional<RequestRoute> route = matched_writer(space);
  if (!route) return std::nullopt;
  return send_oneway(space, route->writer, service, operation, std::move(payload), caller);
}

bool DdsCalls::send_oneway(const std::string& space, fdds::DataWriter* writer, const std::string& service,
                           const std::string& operation, std::string&& payload, const std::string& caller) {
  dds::CallRequest request;
  request.request_id(next_request_id());
  request.caller_space(options_.space);
  request.service(service);
  request.operation(operation);
  request.no_reply(true);
  request.payload(bytes_of(payload));
  request.caller_name(caller);
  request.traceparent(util::outgoing_trace().traceparent());  // the caller's trace, continued there
  if (!writer->write(&request)) return false;
  count_request_bytes(space, request.payload().size());
  // No reply tells when it was served: it stays available to a replier matching late for as long
  // as a replier would take it (kDefaultDeadline), then is retired.
  registrations_.retire_later(writer, request.request_id(), false, Clock::now() + dds_rpc::kDefaultDeadline);
  return true;
}

void DdsCalls::read_replies(fdds::DataReader* reader) {
  dds::CallReply sample;
  fdds::SampleInfo info;
  while (reader->take_next_sample(&sample, &info) == ReturnCode_t::RETCODE_OK) {
    if (!info.valid_data) continue;
    std::shared_ptr<Pending> call;
    {
      std::lock_guard lock(mutex_);
      auto it = pending_.find(sample.request_id());
      if (it == pending_.end()) continue;  // its caller gave up
      // On a secured link only the called space answers: another member's reply is ignored
      // (logged once per writer), the call still waits for the real one.
      if (!identities_.speaks_for(info.publication_handle, it->second->space, "reply to", sample.request_id()))
        continue;
      call = take(sample.request_id());
    }
    {
      const double round_trip = std::chrono::duration<double>(Clock::now() - call->started).count();
      std::lock_guard lock(counts_mutex_);
      if (SpaceCalls* counts = counts_of(call->space)) {
        ++counts->replies;
        counts->reply_bytes += sample.payload().size();
        counts->round_trip_seconds += round_trip;
        counts->last_round_trip_seconds = round_trip;
      }
    }
    call::Reply result;
    const auto status = call::status_from_number(sample.status());
    result.status = status.value_or(call::Status::INTERNAL);
    result.message = status ? sample.message()
                            : "space " + call->space + " answered with status " + std::to_string(sample.status()) +
                                  ", which this bridge does not know: " + sample.message();
    result.exception_type = sample.exception_type();
    result.payload = text_of(sample.payload());
    end(*call, std::move(result));
  }
}

}  // namespace urs::federation
