#pragma once
// CorbaProxyAgent: a service agent whose every call is forwarded to a CORBA object implementing
// the same interface (an RT-Component's provided port, any servant with static skeletons),
// through the Dynamic Invocation Interface. Like AgentServant, it needs no stubs: arguments,
// results and declared user exceptions are converted by CdrCodec with TypeCodes built from the
// interface's descriptors, so one class proxies every interface generated from IDL.
//
// What the caller sees (docs/bridge.md): OK with the reply filled; a declared user
// exception as Outcome::raise with all its fields; otherwise an error status naming the CORBA
// exception. No call outlives CallContext::deadline (the object's call timeout is set for it).

#include <google/protobuf/descriptor.h>
#include <google/protobuf/dynamic_message.h>
#include <omniORB4/CORBA.h>

#include <chrono>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "urs/agent/agent.hpp"
#include "urs/corba_agent/cdr_codec.hpp"

namespace urs::corba_agent {

struct CorbaProxyOptions {
  // Bound on a call whose caller set no deadline (CallContext::deadline is the maximum).
  std::chrono::milliseconds default_deadline{10000};
  // When > 0, no call waits on the target longer than this, whatever the caller's deadline (a
  // per-service bound from configuration); past it the caller gets DEADLINE_EXCEEDED.
  std::chrono::milliseconds max_deadline{0};
  // When set, called on the calling thread after the target answered OBJECT_NOT_EXIST: why it
  // does not exist when its owner knows (e.g. "provider component P is INACTIVE; activate it
  // with `urs rtc act P`"), answered as UNAVAILABLE with that text; "" keeps "provider gone".
  std::function<std::string()> explain_missing_target{};
  // The ORB's bound on calls in flight at once to one process (rtc::OrbOptions::max_calls_per_peer),
  // named in the DEADLINE_EXCEEDED of a call whose deadline passed before it could be sent; 0: not named.
  unsigned max_calls_per_peer = 0;
};

class CorbaProxyAgent : public agent::ServiceAgent {
 public:
  // `interface` must come from IDL (urs.options) and outlive the agent; `target` is duplicated.
  // Throws std::invalid_argument naming what is missing otherwise, or if `target` is nil.
  CorbaProxyAgent(CORBA::ORB_ptr orb, CORBA::Object_ptr target, const google::protobuf::ServiceDescriptor& interface,
                  CorbaProxyOptions options = {});
  ~CorbaProxyAgent() override;

  const google::protobuf::ServiceDescriptor& interface() const override { return interface_; }
  // Thread-safe: each call has its own object reference and request, so calls run side by side.
  agent::Outcome invoke(const google::protobuf::MethodDescriptor& method, const google::protobuf::Message& request,
                        google::protobuf::Message& reply, const agent::CallContext& ctx) override;

 private:
  struct Call;  // how one operation is sent and answered

  // The calling thread's own reference to the target, with `timeout` set on it (omniORB keeps a
  // call timeout per reference; one per thread, so concurrent calls never share a setting).
  CORBA::Object_ptr reference_for(std::chrono::milliseconds timeout) const;
  agent::Outcome answer_user_exception(const Call& call, CORBA::UnknownUserException& raised) const;
  agent::Outcome answer_system_exception(const Call& call, const CORBA::SystemException& raised) const;

  const google::protobuf::ServiceDescriptor& interface_;
  const CorbaProxyOptions options_;
  CORBA::ORB_var orb_;
  std::string target_ior_;
  mutable std::mutex references_mutex_;
  mutable std::map<std::thread::id, CORBA::Object_var> references_;  // one per calling thread
  google::protobuf::DynamicMessageFactory factory_;                  // exception messages; read-only once built
  std::unique_ptr<CdrCodec> codec_;
  std::map<const google::protobuf::MethodDescriptor*, std::unique_ptr<Call>> calls_;
};

}  // namespace urs::corba_agent
