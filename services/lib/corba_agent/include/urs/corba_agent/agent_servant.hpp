#pragma once
// AgentServant: one service agent (urs::agent::ServiceAgent) as a CORBA object, through the
// Dynamic Skeleton Interface. Every operation and attribute accessor of the agent's interface
// (the Protobuf service generated from IDL) is answered: arguments are received with TypeCodes
// built from the descriptors, converted to the Request message, the agent runs on the ORB's
// calling thread, and the Reply becomes the result and the out/inout arguments. CORBA callers
// use the interface's ordinary static stubs (the object's type ID is the interface's repository
// ID). How outcomes map to CORBA exceptions: docs/devices.md.

#include <google/protobuf/dynamic_message.h>
#include <omniORB4/CORBA.h>

#include <chrono>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "urs/agent/agent.hpp"
#include "urs/call/recorder.hpp"
#include "urs/corba_agent/cdr_codec.hpp"

namespace urs::corba_agent {

struct AgentServantOptions {
  std::string service_name;                   // CallContext::service the agent sees
  std::chrono::milliseconds deadline{10000};  // CallContext::deadline, from the call's arrival
  // Where each call is counted when answered (metrics), as service_name and the operation of the
  // interface (an operation it does not have: "other"); null: not counted. Outlives the servant.
  call::CallRecorder* calls = nullptr;
};

class AgentServant : public PortableServer::DynamicImplementation {
 public:
  // `events` must outlive the servant; it is the CallContext::events of every call. Throws
  // std::invalid_argument naming what is missing if the interface was not generated from IDL.
  AgentServant(CORBA::ORB_ptr orb, std::shared_ptr<agent::ServiceAgent> agent, agent::EventSink& events,
               AgentServantOptions options = {});
  ~AgentServant() override;

  // "IDL:URC/Navigation:1.0"; and the IDL scoped name, "URC::Navigation" (an RT port's type_name).
  const std::string& repository_id() const { return repository_id_; }
  std::string interface_name() const;

  void invoke(CORBA::ServerRequest_ptr request) override;
  char* _primary_interface(const PortableServer::ObjectId& id, PortableServer::POA_ptr poa) override;
  CORBA::Boolean _is_a(const char* repository_id) override;

 private:
  struct Operation;

  const Operation& operation(const char* name) const;  // throws CORBA::BAD_OPERATION
  void answer(CORBA::ServerRequest_ptr request, const Operation& op, CORBA::NVList_ptr arguments,
              const agent::Outcome& outcome, const google::protobuf::Message& reply);

  std::shared_ptr<agent::ServiceAgent> agent_;
  agent::EventSink& events_;
  const AgentServantOptions options_;
  CORBA::ORB_var orb_;
  std::string repository_id_;
  std::vector<std::string> base_ids_;
  google::protobuf::DynamicMessageFactory factory_;
  std::unique_ptr<CdrCodec> codec_;
  std::map<std::string, std::unique_ptr<Operation>> operations_;  // by CORBA operation name
};

}  // namespace urs::corba_agent
