#include "urs/bridge/camus_forwarding_agent.hpp"

#include <algorithm>
#include <memory>

#include "camus.pb.h"
#include "urs/planet/call_adapter.hpp"

namespace urs::bridge {

namespace gp = google::protobuf;
using agent::Outcome;
using Clock = std::chrono::steady_clock;

const gp::ServiceDescriptor* describe_service(planet::Client& client, const std::string& service,
                                              schema::SchemaPool& pool, std::chrono::milliseconds timeout,
                                              std::string& error) {
  camus::DescribeRequest request;
  request.set_service(service);
  const auto result = client.call("camus.registry", "Describe", request.SerializeAsString(), timeout);
  if (!result.ok()) {
    error = "describing '" + service + "': " + std::string(planet::status_name(result.status)) + " " + result.message;
    return nullptr;
  }
  camus::DescribeReply reply;
  if (!reply.ParseFromString(result.payload)) {
    error = "describing '" + service + "': camus.registry.Describe returned an unreadable reply";
    return nullptr;
  }
  error = pool.add_descriptor_set(reply.descriptor_set());
  if (!error.empty()) {
    error = "interface of '" + service + "' cannot be loaded: " + error;
    return nullptr;
  }
  const gp::ServiceDescriptor* interface = pool.find_service(reply.interface());
  if (interface == nullptr) error = "the description of '" + service + "' does not define " + reply.interface();
  return interface;
}

CamusForwardingAgent::CamusForwardingAgent(planet::Client& client, std::string service, const gp::ServiceDescriptor& interface)
    : CamusForwardingAgent(
          Route{[&client, service](const std::string& operation, std::string payload, std::chrono::milliseconds deadline,
                                   const call::Identity&) {
                  return planet::to_reply(client.call(service, operation, std::move(payload), deadline));
                },
                [&client, service](const std::string& operation, std::string payload, const call::Identity&) {
                  return client.oneway(service, operation, std::move(payload));
                },
                // The client never blocks to send: the reply comes on its I/O thread.
                [&client, service](const std::string& operation, std::string&& payload,
                                   std::chrono::milliseconds deadline, const call::Identity&, Route::Done done) {
                  client.call_async(service, operation, std::move(payload), deadline,
                                    [done = std::move(done)](planet::CallResult result) {
                                      done(planet::to_reply(std::move(result)));
                                    });
                  return true;
                },
                [&client, service](const std::string& operation, std::string&& payload,
                                   const call::Identity&) -> std::optional<bool> {
                  return client.oneway(service, operation, std::move(payload));
                },
                "the CAMUS server"},
          service, interface) {}

CamusForwardingAgent::CamusForwardingAgent(Route route, std::string service, const gp::ServiceDescriptor& interface)
    : route_(std::move(route)), service_(std::move(service)), interface_(interface) {
  // Exceptions of an interface compiled into the program are made as their generated classes,
  // like the requests and replies its hosts make.
  factory_.SetDelegateToGeneratedFactory(true);
}

Outcome CamusForwardingAgent::invoke(const gp::MethodDescriptor& method, const gp::Message& request, gp::Message& reply,
                                 const agent::CallContext& ctx) {
  std::string payload;
  if (!request.SerializeToString(&payload)) {
    return Outcome::error(call::Status::BAD_ARGUMENTS, "request of " + method.full_name() + " cannot be serialized");
  }
  if (schema::is_oneway(method)) {
    if (!route_.oneway(method.name(), std::move(payload), ctx.caller)) return not_sent(method);
    return Outcome::ok();
  }
  const auto remaining = std::chrono::duration_cast<std::chrono::milliseconds>(ctx.deadline - Clock::now());
  if (remaining.count() <= 0) return too_late(method);
  const auto result = route_.call(method.name(), std::move(payload), remaining, ctx.caller);
  switch (result.status) {
    case call::Status::OK:
      if (!reply.ParseFromString(result.payload)) {
        return Outcome::error(call::Status::INTERNAL, service_ + " replied with an invalid " + reply.GetTypeName());
      }
      return Outcome::ok();
    case call::Status::USER_EXCEPTION: return raised(method, result);
    default: return Outcome::error(result.status, result.message);
  }
}

bool CamusForwardingAgent::forward(const gp::MethodDescriptor& method, call::Request& request,
                                   call::Responder& responder) {
  const bool answers = !request.oneway;
  if (schema::is_oneway(method)) {
    if (!route_.oneway_async) return false;
    const std::optional<bool> sent = route_.oneway_async(method.name(), std::move(request.payload), request.caller);
    if (!sent) return false;
    // invoke()'s outcome as the host answers it: an empty reply, or why it was not sent.
    if (answers) responder.reply(*sent ? call::Reply::success({}) : agent::encode_failure(not_sent(method)));
    return true;
  }
  std::shared_ptr<CamusForwardingAgent> self = weak_from_this().lock();
  if (!route_.call_async || !self) return false;
  const auto remaining = std::chrono::duration_cast<std::chrono::milliseconds>(request.deadline - Clock::now());
  if (remaining.count() <= 0) {
    if (answers) responder.reply(agent::encode_failure(too_late(method)));
    return true;
  }
  // Moved back if the route does not start the call; shared with the completion otherwise, which
  // may run before call_async() returns.
  auto answer = std::make_shared<call::Responder>(std::move(responder));
  auto done = [self = std::move(self), &method, answer, answers](call::Reply result) {
    if (answers) answer->reply(self->handed_back(method, std::move(result)));
  };
  if (route_.call_async(method.name(), std::move(request.payload), remaining, request.caller, std::move(done))) {
    return true;
  }
  responder = std::move(*answer);
  return false;
}

call::Reply CamusForwardingAgent::handed_back(const gp::MethodDescriptor& method, call::Reply result) {
  if (result.status != call::Status::USER_EXCEPTION) return result;
  return agent::encode_failure(raised(method, result));
}

Outcome CamusForwardingAgent::not_sent(const gp::MethodDescriptor& method) const {
  return Outcome::error(call::Status::UNAVAILABLE, service_ + "." + method.name() + " could not be sent to " + route_.to);
}

Outcome CamusForwardingAgent::too_late(const gp::MethodDescriptor& method) const {
  return Outcome::error(call::Status::DEADLINE_EXCEEDED,
                        "the caller's deadline passed before " + service_ + "." + method.name() + " was sent");
}

Outcome CamusForwardingAgent::raised(const gp::MethodDescriptor& method, const call::Reply& result) {
  const auto declared = schema::raises(method);
  if (std::find(declared.begin(), declared.end(), result.exception_type) == declared.end()) {
    return Outcome::error(call::Status::INTERNAL, service_ + "." + method.name() + " raised " + result.exception_type +
                                                ", which it does not declare");
  }
  const gp::Descriptor* type = method.file()->pool()->FindMessageTypeByName(result.exception_type);
  if (type == nullptr) {
    return Outcome::error(call::Status::INTERNAL, "exception " + result.exception_type + " is not in the interface's pool");
  }
  std::shared_ptr<gp::Message> exception(factory_.GetPrototype(type)->New());
  if (!exception->ParseFromString(result.payload)) {
    return Outcome::error(call::Status::INTERNAL, service_ + " raised an invalid " + result.exception_type);
  }
  return Outcome::raise(std::move(exception), result.message);
}

}  // namespace urs::bridge
