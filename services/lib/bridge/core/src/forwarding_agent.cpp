#include "urs/bridge/core/forwarding_agent.hpp"

#include <algorithm>
#include <memory>

#include "urs/schema/schema.hpp"

namespace urs::bridge::core {

namespace gp = google::protobuf;
using agent::Outcome;
using Clock = std::chrono::steady_clock;

ForwardingAgent::ForwardingAgent(std::shared_ptr<CallSink> sink, std::string service,
                                 const gp::ServiceDescriptor& interface)
    : sink_(std::move(sink)), service_(std::move(service)), interface_(interface) {
  // Exceptions of an interface compiled into the program are made as their generated classes,
  // like the requests and replies its hosts make.
  factory_.SetDelegateToGeneratedFactory(true);
}

Outcome ForwardingAgent::invoke(const gp::MethodDescriptor& method, const gp::Message& request, gp::Message& reply,
                                const agent::CallContext& ctx) {
  call::Request out;
  out.service = service_;
  out.operation = method.name();
  out.caller = ctx.caller;
  out.deadline = ctx.deadline;
  if (!request.SerializeToString(&out.payload)) {
    return Outcome::error(call::Status::BAD_ARGUMENTS, "request of " + method.full_name() + " cannot be serialized");
  }
  if (schema::is_oneway(method)) {
    out.oneway = true;
    const call::Reply sent = sink_->call(std::move(out));
    return sent.ok() ? Outcome::ok() : not_sent(method, sent.message);
  }
  if (Clock::now() >= ctx.deadline) return too_late(method);
  const call::Reply result = sink_->call(std::move(out));
  switch (result.status) {
    case call::Status::OK:
      if (!reply.ParseFromString(result.payload)) {
        return Outcome::error(call::Status::INTERNAL, service_ + " replied with an invalid " + reply.GetTypeName());
      }
      return Outcome::ok();
    case call::Status::USER_EXCEPTION:
      return raised(method, result);
    default:
      return Outcome::error(result.status, result.message);
  }
}

bool ForwardingAgent::forward(const gp::MethodDescriptor& method, call::Request& request, call::Responder& responder) {
  const bool answers = !request.oneway;
  std::shared_ptr<ForwardingAgent> self = weak_from_this().lock();
  if (!self) return false;
  const bool oneway = schema::is_oneway(method);
  if (!oneway && Clock::now() >= request.deadline) {
    if (answers) responder.reply(agent::encode_failure(too_late(method)));
    return true;
  }
  call::Request out;
  out.service = service_;
  out.operation = method.name();
  out.deadline = request.deadline;
  out.caller = request.caller;
  out.oneway = oneway;
  out.payload = std::move(request.payload);
  // Moved back if the sink does not start the call; shared with the completion otherwise, which
  // may run before start() returns.
  auto answer = std::make_shared<call::Responder>(std::move(responder));
  CallSink::Done done = [self = std::move(self), &method, answer, answers, oneway](call::Reply result) {
    if (!answers) return;
    if (oneway) {  // invoke()'s outcome as the host answers it: an empty reply, or why it was not sent
      answer->reply(result.ok() ? call::Reply::success({})
                                : agent::encode_failure(self->not_sent(method, result.message)));
      return;
    }
    answer->reply(self->handed_back(method, std::move(result)));
  };
  if (sink_->start(out, std::move(done))) return true;
  request.payload = std::move(out.payload);
  responder = std::move(*answer);
  return false;
}

call::Reply ForwardingAgent::handed_back(const gp::MethodDescriptor& method, call::Reply result) {
  if (result.status != call::Status::USER_EXCEPTION) return result;
  return agent::encode_failure(raised(method, result));
}

Outcome ForwardingAgent::not_sent(const gp::MethodDescriptor& method, const std::string& why) const {
  return Outcome::error(call::Status::UNAVAILABLE, service_ + "." + method.name() + " could not be sent to " +
                                                       sink_->to() + (why.empty() ? "" : ": " + why));
}

Outcome ForwardingAgent::too_late(const gp::MethodDescriptor& method) const {
  return Outcome::error(call::Status::DEADLINE_EXCEEDED,
                        "the caller's deadline passed before " + service_ + "." + method.name() + " was sent");
}

Outcome ForwardingAgent::raised(const gp::MethodDescriptor& method, const call::Reply& result) {
  const auto declared = schema::raises(method);
  if (std::find(declared.begin(), declared.end(), result.exception_type) == declared.end()) {
    return Outcome::error(call::Status::INTERNAL, service_ + "." + method.name() + " raised " + result.exception_type +
                                                      ", which it does not declare");
  }
  const gp::Descriptor* type = method.file()->pool()->FindMessageTypeByName(result.exception_type);
  if (type == nullptr) {
    return Outcome::error(call::Status::INTERNAL,
                          "exception " + result.exception_type + " is not in the interface's pool");
  }
  std::shared_ptr<gp::Message> exception(factory_.GetPrototype(type)->New());
  if (!exception->ParseFromString(result.payload)) {
    return Outcome::error(call::Status::INTERNAL, service_ + " raised an invalid " + result.exception_type);
  }
  return Outcome::raise(std::move(exception), result.message);
}

}  // namespace urs::bridge::core
