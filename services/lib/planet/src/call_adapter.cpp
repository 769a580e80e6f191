#include "urs/planet/call_adapter.hpp"

#include <algorithm>
#include <memory>
#include <utility>

namespace urs::planet {

namespace {

// call::Status and the Planet wire Status are one set of numbers: to_call/to_planet are casts.
constexpr bool same_number(call::Status neutral, Status wire) {
  return static_cast<int>(neutral) == static_cast<int>(wire);
}
static_assert(same_number(call::Status::OK, OK));
static_assert(same_number(call::Status::UNKNOWN_SERVICE, UNKNOWN_SERVICE));
static_assert(same_number(call::Status::UNKNOWN_OPERATION, UNKNOWN_OPERATION));
static_assert(same_number(call::Status::BAD_ARGUMENTS, BAD_ARGUMENTS));
static_assert(same_number(call::Status::PROVIDER_GONE, PROVIDER_GONE));
static_assert(same_number(call::Status::DEADLINE_EXCEEDED, DEADLINE_EXCEEDED));
static_assert(same_number(call::Status::INTERNAL, INTERNAL));
static_assert(same_number(call::Status::USER_EXCEPTION, USER_EXCEPTION));
static_assert(same_number(call::Status::UNAVAILABLE, UNAVAILABLE));
static_assert(same_number(call::Status::UNAUTHENTICATED, UNAUTHENTICATED));
static_assert(same_number(call::Status::PAYLOAD_TOO_LARGE, PAYLOAD_TOO_LARGE));
static_assert(same_number(call::Status::ALREADY_EXISTS, ALREADY_EXISTS));
static_assert(same_number(call::Status::NOT_FOUND, NOT_FOUND));
static_assert(same_number(call::Status::RESOURCE_EXHAUSTED, RESOURCE_EXHAUSTED));
static_assert(same_number(call::Status::PERMISSION_DENIED, PERMISSION_DENIED));
static_assert(call::kLastStatus == Status_MAX, "a Planet status has no call::Status: add it to urs/call/call.hpp");

}  // namespace

call::Status to_call(Status status) {
  return call::status_from_number(static_cast<int>(status)).value_or(call::Status::INTERNAL);
}

Status to_planet(call::Status status) { return static_cast<Status>(call::status_number(status)); }

call::Reply to_reply(CallResult result) {
  return {to_call(result.status), std::move(result.message), std::move(result.payload),
          std::move(result.exception_type)};
}

CallResult to_call_result(call::Reply reply) {
  return {to_planet(reply.status), std::move(reply.message), std::move(reply.payload), std::move(reply.exception_type)};
}

call::Identity caller_identity(const std::string& space, const std::string& name, Role role) {
  return {space, name, role_word(role)};
}

call::Identity caller_identity(const std::string& space, const Identity& identity) {
  return caller_identity(space, identity.name, identity.role);
}

call::Identity routed_caller(const Request& request, const std::string& space) {
  if (!request.has_caller() || request.caller().name().empty()) return {};
  return caller_identity(space, request.caller().name(), request.caller().role());
}

call::Request to_call_request(const Request& request, call::Identity caller,
                              std::chrono::steady_clock::time_point received) {
  call::Request out;
  out.service = request.service();
  out.operation = request.operation();
  out.payload = request.payload();
  if (request.deadline_ms() != 0) {
    // A deadline past what a time_point holds is no deadline.
    const auto room =
        std::chrono::duration_cast<std::chrono::milliseconds>(std::chrono::steady_clock::time_point::max() - received);
    if (request.deadline_ms() < static_cast<uint64_t>(room.count())) {
      out.deadline = received + std::chrono::milliseconds(request.deadline_ms());
    }
  }
  out.caller = std::move(caller);
  out.oneway = request.oneway();
  out.traceparent = request.traceparent();
  return out;
}

call::Responder to_call_responder(Responder responder) { return std::move(responder).neutral(); }

call::Responder to_call_responder(std::function<void(CallResult)> done) {
  if (!done) return call::Responder();
  return call::Responder::from_callback(
      [done = std::move(done)](call::Reply reply) { done(to_call_result(std::move(reply))); });
}

ReplyHandler answering(call::Responder responder) {
  auto shared = std::make_shared<call::Responder>(std::move(responder));
  return [shared](CallResult result) { shared->reply(to_reply(std::move(result))); };
}

std::chrono::milliseconds deadline_left(const call::Request& request, std::chrono::steady_clock::time_point now) {
  if (!request.has_deadline()) return std::chrono::milliseconds{0};
  return std::max(std::chrono::milliseconds{1},
                  std::chrono::duration_cast<std::chrono::milliseconds>(request.deadline - now));
}

}  // namespace urs::planet
