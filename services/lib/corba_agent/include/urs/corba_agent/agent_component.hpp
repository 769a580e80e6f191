#pragma once
// AgentComponent: one service agent as an RT-Component. A service port offers the agent through
// an AgentServant under the interface's IDL scoped name ("URC::Navigation"); the agent's events
// on configured topics leave through data OutPorts as the CDR of their IDL struct, so OpenRTM-aist
// InPorts of that type can take them. The agent starts when the component is initialized (calls
// are answered whatever the component's state, as a service port's are) and stops at finalize.

#include <yaml-cpp/yaml.h>

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
// make_agent and the keys above throw urs::util::ConfigError naming the key.
rtc::ComponentFactory agent_component_factory(
    std::string type_name, std::function<std::shared_ptr<agent::ServiceAgent>(const YAML::Node& params)> make_agent);

}  // namespace urs::corba_agent
