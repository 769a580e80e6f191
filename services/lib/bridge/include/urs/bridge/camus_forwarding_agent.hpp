#pragma once
// CamusForwardingAgent: a service agent that forwards every call to a CAMUS service: over Planet
// to this space's CAMUS server, or over DDS to the bridge of the space that offers it.
//
// It knows nothing of the interface at compile time: the descriptor it is given (typically the
// service's description fetched from the CAMUS registry by describe_service()) drives everything,
// so any host of service agents (corba_agent::AgentServant, an AgentHost) can offer a CAMUS
// service the program was not compiled with.
//
// Outcomes: the reply of a successful call fills `reply`; a declared IDL exception is raised as
// that exception's message; every other status is returned as is, with its message (the
// host maps it, e.g. UNKNOWN_SERVICE / PROVIDER_GONE / UNAVAILABLE become CORBA::TRANSIENT). The
// call's deadline is what remains of CallContext::deadline. Oneway operations are sent and not
// waited for.
//
// Threads: invoke() blocks until the reply (an AgentHost's worker, a CORBA thread). Hosted by an
// AgentHost, the agent takes most calls through forward() instead, on the thread that received
// them and without blocking: the request's bytes are sent on unparsed, and the reply's handed back
// as they came, from the thread the route's reply arrives on (a DDS listener, the Planet client's
// I/O thread); only a raised exception is parsed, to check it is declared. A call the route cannot
// start without blocking (DDS: the first to a space, waiting for discovery) goes to invoke().

#include <google/protobuf/descriptor.h>
#include <google/protobuf/dynamic_message.h>

#include <chrono>
#include <functional>
#include <memory>
#include <optional>
#include <string>

#include "urs/agent/agent.hpp"
#include "urs/call/call.hpp"
#include "urs/planet/client.hpp"
#include "urs/schema/schema.hpp"

namespace urs::bridge {

// Asks the CAMUS registry (camus.registry.Describe) for the interface of `service`, adds its
// description to `pool` and returns the interface's descriptor, valid as long as `pool`.
// On failure returns nullptr and sets `error` (the registry's status and message, or why the
// description cannot be used). Blocking; not to be called from a Planet callback.
const google::protobuf::ServiceDescriptor* describe_service(planet::Client& client, const std::string& service,
                                                            schema::SchemaPool& pool, std::chrono::milliseconds timeout,
                                                            std::string& error);

// Made shared (std::make_shared): a forwarded call keeps its agent until its reply is handed back.
class CamusForwardingAgent : public agent::ServiceAgent,
                             public std::enable_shared_from_this<CamusForwardingAgent> {
 public:
  // How calls reach the service: a Planet client, or another space over DDS (DdsLink carries the
  // same requests, statuses and exceptions). `caller` is the call's CallContext::caller, which a
  // route may pass on (DDS: the name inside this space) or not (Planet: the client calls as itself).
  struct Route {
    using Done = std::function<void(call::Reply)>;
    // Blocking; may wait for the route to be ready (DDS: a first match), then for the reply.
    std::function<call::Reply(const std::string& operation, std::string payload, std::chrono::milliseconds deadline,
                              const call::Identity& caller)>
        call;
    std::function<bool(const std::string& operation, std::string payload, const call::Identity& caller)>
        oneway;  // false: not sent
    // `call` without blocking: `done` gets the reply, once, from any thread (maybe before this
    // returns). False, with nothing sent, `payload` untouched and `done` dropped uncalled, when the
    // call cannot start without blocking (`call` makes it then). Empty: the route has none.
    std::function<bool(const std::string& operation, std::string&& payload, std::chrono::milliseconds deadline,
                       const call::Identity& caller, Done done)>
        call_async;
    // `oneway` without blocking: whether it was sent; nullopt, with nothing sent and `payload`
    // untouched, when it cannot be sent without blocking. Empty: the route has none.
    std::function<std::optional<bool>(const std::string& operation, std::string&& payload,
                                      const call::Identity& caller)>
        oneway_async;
    std::string to;  // for messages, e.g. "the CAMUS server", "space jp"
  };

  // `client` and the pool holding `interface` must outlive the agent; `service` is the CAMUS
  // service name calls are sent to.
  CamusForwardingAgent(planet::Client& client, std::string service, const google::protobuf::ServiceDescriptor& interface);
  CamusForwardingAgent(Route route, std::string service, const google::protobuf::ServiceDescriptor& interface);

  const google::protobuf::ServiceDescriptor& interface() const override { return interface_; }
  agent::Outcome invoke(const google::protobuf::MethodDescriptor& method, const google::protobuf::Message& request,
                        google::protobuf::Message& reply, const agent::CallContext& ctx) override;
  // Takes the call if the route can start it without blocking (see above).
  bool forward(const google::protobuf::MethodDescriptor& method, call::Request& request,
               call::Responder& responder) override;

  const std::string& service() const { return service_; }

 private:
  agent::Outcome raised(const google::protobuf::MethodDescriptor& method, const call::Reply& result);
  // The reply forward() hands back for the route's `result`: as it came, but an exception checked.
  call::Reply handed_back(const google::protobuf::MethodDescriptor& method, call::Reply result);
  agent::Outcome not_sent(const google::protobuf::MethodDescriptor& method) const;
  agent::Outcome too_late(const google::protobuf::MethodDescriptor& method) const;

  const Route route_;
  const std::string service_;
  const google::protobuf::ServiceDescriptor& interface_;
  google::protobuf::DynamicMessageFactory factory_;  // the exceptions raised, when not compiled in
};

}  // namespace urs::bridge
