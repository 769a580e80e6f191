#pragma once
// ForwardingAgent: a service agent that forwards every call to a service reached through a
// CallSink (a CAMUS server over Planet, another space over DDS, an in-memory side), so that any
// host of agents (an AgentHost, an RT-Component's provider port) can stand for it.
//
// It knows nothing of the interface at compile time: the descriptor it is given (the service's
// description, from its registry or catalog) drives everything, so a host can offer a service the
// program was not compiled with.
//
// Outcomes: the reply of a successful call fills `reply`; a declared IDL exception is raised as
// that exception's message; every other status is returned as is, with its message (the host maps
// it, e.g. UNKNOWN_SERVICE / PROVIDER_GONE / UNAVAILABLE become CORBA::TRANSIENT). The call's
// deadline is the caller's. Oneway operations are sent and not waited for.
//
// Threads: invoke() blocks until the reply (an AgentHost's worker, a CORBA thread). Hosted by an
// AgentHost, the agent takes most calls through forward() instead, on the thread that received
// them and without blocking: the request's bytes are sent on unparsed, and the reply's handed back
// as they came, from the thread the sink's reply arrives on; only a raised exception is parsed, to
// check it is declared. A call the sink cannot start without blocking (DDS: the first to a space,
// waiting for discovery) goes to invoke().

#include <google/protobuf/descriptor.h>
#include <google/protobuf/dynamic_message.h>

#include <functional>
#include <memory>
#include <string>

#include "urs/agent/agent.hpp"
#include "urs/call/call.hpp"

namespace urs::bridge::core {

// Where a forwarding agent's calls go. `request.service` is the service's name there.
class CallSink {
 public:
  using Done = std::function<void(call::Reply)>;
  virtual ~CallSink() = default;
  // Starts `request` if that needs no wait: `done` gets the reply once, from any thread (maybe
  // before this returns); a oneway request's reply is OK once sent, UNAVAILABLE if it cannot be.
  // False, with nothing sent, `request` untouched and `done` dropped uncalled, when it would wait.
  virtual bool start(call::Request& request, Done done) = 0;
  // The call, blocking until its reply (or its deadline); a oneway request returns once sent
  // (OK), or UNAVAILABLE.
  virtual call::Reply call(call::Request request) = 0;
  // Where it goes, for messages: "the CAMUS server", "space jp".
  virtual std::string to() const = 0;
};

// Made shared (std::make_shared): a forwarded call keeps its agent until its reply is handed back.
class ForwardingAgent : public agent::ServiceAgent, public std::enable_shared_from_this<ForwardingAgent> {
 public:
  // `service` is the service's name at the sink; the pool holding `interface` outlives the agent.
  ForwardingAgent(std::shared_ptr<CallSink> sink, std::string service,
                  const google::protobuf::ServiceDescriptor& interface);

  const google::protobuf::ServiceDescriptor& interface() const override { return interface_; }
  agent::Outcome invoke(const google::protobuf::MethodDescriptor& method, const google::protobuf::Message& request,
                        google::protobuf::Message& reply, const agent::CallContext& ctx) override;
  // Takes the call if the sink can start it without blocking (see above).
  bool forward(const google::protobuf::MethodDescriptor& method, call::Request& request,
               call::Responder& responder) override;

  const std::string& service() const { return service_; }

 private:
  agent::Outcome raised(const google::protobuf::MethodDescriptor& method, const call::Reply& result);
  // The reply forward() hands back for the sink's `result`: as it came, but an exception checked.
  call::Reply handed_back(const google::protobuf::MethodDescriptor& method, call::Reply result);
  agent::Outcome not_sent(const google::protobuf::MethodDescriptor& method, const std::string& why) const;
  agent::Outcome too_late(const google::protobuf::MethodDescriptor& method) const;

  const std::shared_ptr<CallSink> sink_;
  const std::string service_;
  const google::protobuf::ServiceDescriptor& interface_;
  google::protobuf::DynamicMessageFactory factory_;  // the exceptions raised, when not compiled in
};

}  // namespace urs::bridge::core
