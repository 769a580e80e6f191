#include "urs/bridge/core/call_meter.hpp"

#include <spdlog/spdlog.h>

#include <atomic>
#include <chrono>
#include <optional>
#include <utility>

#include "urs/bridge/core/route_reconciler.hpp"
#include "urs/schema/schema.hpp"
#include "urs/util/trace.hpp"

namespace urs::bridge::core {

namespace gp = google::protobuf;
using Clock = std::chrono::steady_clock;

namespace {

// The trace a call works for: its request's, else the one of the thread that received it.
std::optional<util::TraceContext> trace_of(const std::string& traceparent) {
  if (auto parsed = util::TraceContext::parse(traceparent)) return parsed;
  if (const util::TraceContext* current = util::current_trace()) return *current;
  return std::nullopt;
}

}  // namespace

struct MeteredAgent::Ended {
  const MeteredAgent* agent;  // alive until the call ends
  std::string operation;
  std::optional<util::TraceContext> trace;
  Clock::time_point start;

  void operator()(call::Status status) const noexcept {
    const auto elapsed = Clock::now() - start;
    if (agent->calls_ != nullptr) agent->calls_->record(agent->service_, operation, status, elapsed);
    if (!spdlog::should_log(spdlog::level::debug)) return;
    try {
      const util::TraceScope scope(trace);
      spdlog::debug("bridged {}.{} ({}): {} in {} us", agent->service_, operation, agent->direction_,
                    call::status_name(status), std::chrono::duration_cast<std::chrono::microseconds>(elapsed).count());
    } catch (...) {
      // A log line that cannot be written never fails the call it describes.
    }
  }
};

MeteredAgent::MeteredAgent(std::shared_ptr<agent::ServiceAgent> inner, std::string direction, std::string service,
                           call::CallRecorder* calls)
    : inner_(std::move(inner)), direction_(std::move(direction)), service_(std::move(service)), calls_(calls) {}

agent::Outcome MeteredAgent::invoke(const gp::MethodDescriptor& method, const gp::Message& request, gp::Message& reply,
                                    const agent::CallContext& ctx) {
  if (schema::is_oneway(method)) return inner_->invoke(method, request, reply, ctx);
  const Ended ended{this, method.name(), trace_of({}), Clock::now()};
  agent::Outcome outcome;
  try {
    outcome = inner_->invoke(method, request, reply, ctx);
  } catch (...) {
    ended(call::Status::INTERNAL);  // what the host answers for it
    throw;
  }
  ended(outcome.status);
  return outcome;
}

bool MeteredAgent::forward(const gp::MethodDescriptor& method, call::Request& request, call::Responder& responder) {
  std::optional<util::TraceContext> trace = trace_of(request.traceparent);
  const util::TraceScope scope(trace);
  if (request.oneway) return inner_->forward(method, request, responder);
  std::shared_ptr<const MeteredAgent> owner = weak_from_this().lock();  // kept until the call ends
  if (!owner) return inner_->forward(method, request, responder);       // not made shared: not metered
  Ended ended{owner.get(), method.name(), std::move(trace), Clock::now()};
  auto original = std::make_shared<call::Responder>(std::move(responder));
  auto taken = std::make_shared<std::atomic<bool>>(true);
  call::Responder metered = call::Responder::from_callback(
      [owner = std::move(owner), original, taken, ended = std::move(ended)](call::Reply reply) {
        if (!taken->load(std::memory_order_acquire)) return;  // not taken: the host runs it as usual
        ended(reply.status);
        original->reply(std::move(reply));
      });
  if (inner_->forward(method, request, metered)) return true;
  taken->store(false, std::memory_order_release);
  responder = std::move(*original);
  return false;  // `metered`, unanswered, answers nobody
}

std::shared_ptr<agent::ServiceAgent> MeteredSource::serve(const Route& route) {
  return std::make_shared<MeteredAgent>(source_.serve(route), direction_, route.name, calls_);
}

}  // namespace urs::bridge::core
