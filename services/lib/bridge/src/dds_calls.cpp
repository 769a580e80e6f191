#include "dds_calls.hpp"

#include <spdlog/spdlog.h>

#include <cstdio>
#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/publisher/Publisher.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>
#include <fastdds/dds/subscriber/Subscriber.hpp>
#include <fastdds/dds/topic/Topic.hpp>
#include <random>
#include <stdexcept>

#include "Federation.h"
#include "dds_participant.hpp"
#include "dds_rpc.hpp"

namespace urs::bridge {

namespace fdds = eprosima::fastdds::dds;
using dds_rpc::bytes_of;
using dds_rpc::text_of;

namespace {

// How long a call to a space waits for its request writer to match a bridge of that space
// (discovery, for the first call to it). The wait is on a condition variable the writer's
// matched-status listener signals, on a DDS listener thread: so call() and oneway() never run on
// one (nor on a Planet client's I/O thread, which they would hold up). The bridge calls them from
// its agent host's workers (CamusForwardingAgent) and CORBA's threads; what arrives over DDS
// (serve_remote) is only dispatched or sent on asynchronously.
constexpr std::chrono::milliseconds kMatchWait{2000};

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
      }()) {}

void DdsCalls::open(fdds::DataReaderListener* listener) {
  reply_reader_ = participant_.subscriber()->create_datareader(
      participant_.topic(reply_name_, participant_.reply_type), dds_rpc::rpc_reader_qos(), listener);
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

void DdsCalls::fail_pending(const std::string& space) {
  std::vector<std::shared_ptr<Pending>> failed;
  {
    std::lock_guard lock(mutex_);
    for (auto it = pending_.begin(); it != pending_.end();) {
      if (it->second->space == space) {
        failed.push_back(it->second);
        it = pending_.erase(it);
      } else {
        ++it;
      }
    }
  }
  for (auto& call : failed) {
    call->promise.set_value(
        call::Reply::error(call::Status::PROVIDER_GONE, "the bridge of space " + space + " left during the call"));
  }
}

void DdsCalls::close() {
  std::vector<std::shared_ptr<Pending>> left;
  {
    std::lock_guard lock(mutex_);  // a call registers its pending reply under it, closing or not
    for (auto& listener : writer_listeners_) listener->wake();
    for (auto& [id, call] : pending_) left.push_back(call);
    pending_.clear();
  }
  for (auto& call : left) call->promise.set_value(call::Reply::error(call::Status::UNAVAILABLE, "bridge stopping"));
}

call::Reply DdsCalls::call(const std::string& space, const std::string& service, const std::string& operation,
                           std::string payload, std::chrono::milliseconds deadline, const std::string& caller) {
  const auto until = Clock::now() + deadline;
  const std::string id = next_request_id();
  auto pending = std::make_shared<Pending>();
  pending->space = space;
  auto answer = pending->promise.get_future();
  RequestRoute route;
  try {
    std::lock_guard lock(mutex_);
    if (gate_.closing()) return call::Reply::error(call::Status::UNAVAILABLE, "bridge stopping");
    route = request_writer(space);
    pending_[id] = pending;
  } catch (const std::exception& e) {
    if (options_.security.enabled()) {  // on a secured link, the access control refused the writer
      return call::Reply::error(call::Status::PERMISSION_DENIED, "the permissions of space " + options_.space +
                                                                     " do not grant calls to space " + space);
    }
    return call::Reply::error(call::Status::UNAVAILABLE, e.what());
  }
  fdds::DataWriter* writer = route.writer;
  auto forget = [&] {
    std::lock_guard lock(mutex_);
    pending_.erase(id);
  };
  // A writer made for this call waits for discovery; a known space's is matched already.
  if (!route.listener->wait_matched(std::min(until, Clock::now() + kMatchWait))) {
    forget();
    if (gate_.closing()) return call::Reply::error(call::Status::UNAVAILABLE, "bridge stopping");
    return call::Reply::error(call::Status::UNAVAILABLE, "space " + space + " is not reachable over DDS (no bridge of it matched)");
  }
  dds::CallRequest request;
  request.request_id(id);
  request.caller_space(options_.space);
  request.service(service);
  request.operation(operation);
  request.deadline_ms(static_cast<uint32_t>(
      std::max<int64_t>(1, std::chrono::duration_cast<std::chrono::milliseconds>(until - Clock::now()).count())));
  request.no_reply(false);
  request.payload(bytes_of(payload));
  request.caller_name(caller);
  spdlog::debug("dds: request {} to space {}: {}.{}", id, space, service, operation);
  if (!writer->write(&request)) {
    forget();
    return call::Reply::error(call::Status::UNAVAILABLE, "the request to space " + space + " could not be written");
  }
  // Whatever the outcome, nobody waits for this request any more: a replier matching later must
  // not execute it, and the one that did may forget its reply.
  const bool answered = answer.wait_until(until) == std::future_status::ready;
  RpcRegistrations::retire(writer, id, false);
  if (!answered) {
    forget();
    return call::Reply::error(call::Status::DEADLINE_EXCEEDED, "no reply from space " + space + " for " + service +
                                                                    "." + operation + " within " +
                                                                    std::to_string(deadline.count()) + " ms");
  }
  return answer.get();
}

bool DdsCalls::oneway(const std::string& space, const std::string& service, const std::string& operation,
                      std::string payload, const std::string& caller) {
  RequestRoute route;
  try {
    std::lock_guard lock(mutex_);
    if (gate_.closing()) return false;
    route = request_writer(space);
  } catch (const std::exception&) {
    return false;
  }
  if (!route.listener->wait_matched(Clock::now() + kMatchWait)) return false;
  fdds::DataWriter* writer = route.writer;
  dds::CallRequest request;
  request.request_id(next_request_id());
  request.caller_space(options_.space);
  request.service(service);
  request.operation(operation);
  request.no_reply(true);
  request.payload(bytes_of(payload));
  request.caller_name(caller);
  if (!writer->write(&request)) return false;
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
      call = it->second;
      // On a secured link only the called space answers: another member's reply is ignored
      // (logged once per writer), the call still waits for the real one.
      if (!identities_.speaks_for(info.publication_handle, call->space, "reply to", sample.request_id())) continue;
      pending_.erase(it);
    }
    call::Reply result;
    const auto status = call::status_from_number(sample.status());
    result.status = status.value_or(call::Status::INTERNAL);
    result.message = status ? sample.message()
                            : "space " + call->space + " answered with status " + std::to_string(sample.status()) +
                                  ", which this bridge does not know: " + sample.message();
    result.exception_type = sample.exception_type();
    result.payload = text_of(sample.payload());
    call->promise.set_value(std::move(result));
  }
}

}  // namespace urs::bridge
