#pragma once
// Calling an operation of an RT-Component's provider port from JSON-free messages and the
// interface's description, as a foreign RT consumer does (RTC-INTEROP.md: a connection holding
// only that port publishes its IOR), through the Dynamic Invocation Interface: no stubs, any
// interface the catalog describes. `urs rtc call` and urs-gateway's RT operations both use it.

#include <google/protobuf/descriptor.h>
#include <google/protobuf/message.h>

#include <chrono>
#include <string>

#include "RTC.hh"
#include "urs/agent/agent.hpp"
#include "urs/rtc/orb.hpp"
#include "urs/schema/interface_catalog.hpp"

namespace urs::rt_call {

struct ProviderTarget {
  std::string ior;                                                 // the provided object
  std::string type_name;                                           // e.g. "URC::Navigation"
  const google::protobuf::ServiceDescriptor* interface = nullptr;  // its description
  std::string error;                                               // why there is none ("" if found)
};

// What `port` (named `what` in messages) provides, of type `type_name` if not empty, and the
// catalog's description of it. Blocking (two CORBA calls: connect, disconnect); CORBA system
// exceptions propagate.
ProviderTarget provider_target(RTC::PortService_ptr port, const schema::InterfaceCatalog& catalog,
                               const std::string& type_name, const std::string& what);

// What a call came to. An IDL exception is given as its type and its fields in JSON: the message
// the consumer decoded does not outlive the call.
struct ProviderOutcome {
  call::Status status = call::Status::OK;
  std::string message;
  std::string exception_type;  // USER_EXCEPTION: the exception's Protobuf full name, e.g. "URS.Failure"
  std::string exception_json;  // and its fields, e.g. {"reason":"jammed","code":9}
};

// Calls `method` of `target` with `request`, filling `reply` on OK; the outcome names the IDL
// exception or the CORBA failure. Bounded by `deadline`. Blocking; never throws for a CORBA failure.
ProviderOutcome call_provider(const rtc::Orb& orb, const ProviderTarget& target,
                              const google::protobuf::MethodDescriptor& method,
                              const google::protobuf::Message& request, google::protobuf::Message& reply,
                              std::chrono::milliseconds deadline, const std::string& what);

}  // namespace urs::rt_call
