#pragma once
// AgentComponent: one service agent as an RT-Component. A service port offers the agent through
// an AgentServant under the interface's IDL scoped name ("URC::Navigation"); the agent's events
// on configured topics leave through data OutPorts as the CDR of their IDL struct, so OpenRTM-aist
// InPorts of that type can take them. The agent starts when the component is initialized (calls
// are answered whatever the component's state, unless Component::serve_while_inactive(false)
// makes the service port follow it as OpenRTM-aist's do) and stops at finalize.
// An agent that is agent::Tunable offers its parameters as the component's configuration
// parameters: a tool's change (rtconf set, `urs rtc conf set`) reaches the agent at once.

#include <google/protobuf/dynamic_message.h>
#include <yaml-cpp/yaml.h>

#include <chrono>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "urs/agent/agent.hpp"
#include "urs/corba_agent/agent_servant.hpp"
#include "urs/rtc/component.hpp"
#include "urs/rtc/corba_port.hpp"
#include "urs/rtc/data_port.hpp"
#include "urs/rtc/manager.hpp"

namespace urs::corba_agent {

// A data OutPort whose values are Planet messages sent as the CDR of their IDL struct, exception or
// union (dataport.data_type = its repository ID, e.g. "IDL:URC/PoseWithCovariance:1.0").
class RawOutPort : public rtc::OutPortBase {
 public:
  // Throws std::invalid_argument if `type` has no repository ID (not an IDL struct, exception or union).
  RawOutPort(std::string name, const google::protobuf::Descriptor& type);
  // Throws ConversionError (nothing is sent) for a value IDL cannot hold, std::invalid_argument for
  // a message of another type.
  WriteResult write(const google::protobuf::Message& value);

 private:
  const google::protobuf::Descriptor& type_;
  CdrCodec codec_;
};

// A data InPort taking values as the CDR of an IDL struct, exception or union and handing each to
// `handler` as a Planet message of `type` (dataport.data_type = the type's repository ID). The
// handler runs in the ORB's thread for each value, after it is decoded; an exception it throws is
// logged and the value still counts as received. A payload that is not one value is refused
// (PORT_ERROR) and never reaches the handler.
class RawInPort : public rtc::InPortBase {
 public:
  using Handler = std::function<void(const google::protobuf::Message& value)>;
  // Throws std::invalid_argument if `type` has no repository ID.
  RawInPort(std::string name, const google::protobuf::Descriptor& type, Handler handler,
            std::size_t buffer_length = 64);
  ~RawInPort() override;  // disconnects first, so no put() reaches a half-destroyed port

  const google::protobuf::Descriptor& type() const { return type_; }

 protected:
  void store(cdrMemoryStream& stream) override;

 private:
  const google::protobuf::Descriptor& type_;
  CdrCodec codec_;
  google::protobuf::DynamicMessageFactory factory_;
  Handler handler_;
};

struct EventStream {
  std::string topic;  // the agent's event topic
  std::string port;   // the OutPort's name
  std::string type;   // full Protobuf name of the event message, e.g. "URC.PoseWithCovariance"
};

struct AgentComponentConfig {
  std::string type_name;           // the component type, e.g. "Diagnostic"
  std::string port;                // the service port; empty: the interface name in lower case
  std::string interface_instance;  // empty: the same as the port
  std::vector<EventStream> streams;
  std::chrono::milliseconds deadline{10000};  // CallContext::deadline of each call, from its arrival
  call::CallRecorder* calls = nullptr;        // AgentServantOptions::calls
};

class AgentComponent : public rtc::Component {
 public:
  // Throws std::invalid_argument for a stream whose type is not in the agent's descriptor pool or
  // is not an IDL struct, exception or union, or for two streams on one topic or one port.
  AgentComponent(AgentComponentConfig config, std::shared_ptr<agent::ServiceAgent> agent);
  ~AgentComponent() override;

  const AgentComponentConfig& config() const { return config_; }
  // The OutPort of a stream; nullptr if none has that name.
  RawOutPort* out_port(const std::string& name);

 protected:
  RTC::ReturnCode_t handle_initialize() override;
  RTC::ReturnCode_t handle_finalize() override;

 private:
  class Sink;

  AgentComponentConfig config_;
  std::shared_ptr<agent::ServiceAgent> agent_;
  std::unique_ptr<Sink> sink_;
  std::unique_ptr<AgentServant> servant_;  // outlives port_: declared first, destroyed last
  rtc::CorbaPort port_;
  std::vector<std::unique_ptr<RawOutPort>> out_ports_;
  bool started_ = false;
};

// A factory for urs-rtc-manager's catalog: the component's config keys are
//   params:              handed to make_agent (the device's own parameters)
//   port:                the service port's name (default: the interface name in lower case)
//   interface_instance:  the provided interface's instance name (default: the port's name)
//   streams:             [{topic: <event topic>, port: <OutPort name>, type: <Protobuf message>}]
//   deadline_ms:         the deadline the agent sees for each call (AgentComponentConfig::deadline)
// make_agent and the keys above throw urs::util::ConfigError naming the key. With `calls`, the
// components' calls are counted there (AgentServantOptions::calls; it outlives them).
rtc::ComponentFactory agent_component_factory(
    std::string type_name, std::function<std::shared_ptr<agent::ServiceAgent>(const YAML::Node& params)> make_agent,
    call::CallRecorder* calls = nullptr);

}  // namespace urs::corba_agent
