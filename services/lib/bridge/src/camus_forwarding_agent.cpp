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
    if (!route_.oneway(method.name(), std::move(payload), ctx.caller)) {
      return Outcome::error(call::Status::UNAVAILABLE, service_ + "." + method.name() + " could not be sent to " + route_.to);
    }
    return Outcome::ok();
  }
  const auto remaining = std::chrono::duration_cast<std::chrono::milliseconds>(ctx.deadline - Clock::now());
  if (remaining.count() <= 0) {
    return Outcome::error(call::Status::DEADLINE_EXCEEDED, "the caller's deadline passed before " + service_ + "." +
                                                         method.name() + " was sent");
  }
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
