#pragma once
// BridgeComponent: the bridge's own RT-Component (internal). Its lifecycle drives the bridge
// (activated: a session opens; deactivated or finalized: it closes); its ports are where RT
// providers and data ports are connected: "providers" (ProviderPort), "in<N>" per data_to_camus
// entry, "out<N>" per events_to_rt entry.

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "urs/corba_agent/agent_component.hpp"
#include "urs/rt_call/provider_port.hpp"
#include "urs/rtc/component.hpp"
#include "urs/schema/interface_catalog.hpp"

namespace urs::bridge {

class BridgeComponent : public rtc::Component {
 public:
  // Called on the component's threads: `set_active` from its lifecycle callbacks, `on_data` with
  // each value arriving at in<N> (N: the data_to_camus entry).
  struct Hooks {
    std::function<void(bool active)> set_active;
    std::function<void(std::size_t entry, const google::protobuf::Message& value)> on_data;
  };
  // `bridge` is the bridge's name; in<N> carries values of in_types[N], out<N> of out_types[N]
  // (known, checked by RtSide).
  BridgeComponent(const std::string& bridge, const std::vector<const google::protobuf::Descriptor*>& in_types,
                  const std::vector<const google::protobuf::Descriptor*>& out_types, Hooks hooks);

  rt_call::ProviderPort& providers() { return providers_; }
  corba_agent::RawInPort& in_port(std::size_t entry) { return *in_ports_.at(entry); }
  corba_agent::RawOutPort& out_port(std::size_t entry) { return *out_ports_.at(entry); }
  // The port a link key names ("<peer port>": providers; "<peer port>#<ours>": that data port).
  // Throws std::logic_error for a port it does not have.
  rtc::PortBase& port_of_link(const std::string& link);

 protected:
  RTC::ReturnCode_t handle_initialize() override;
  RTC::ReturnCode_t handle_activated(RTC::ExecutionContextHandle_t) override;
  RTC::ReturnCode_t handle_deactivated(RTC::ExecutionContextHandle_t) override;
  RTC::ReturnCode_t handle_finalize() override;

 private:
  const std::string planet_peer_;
  const Hooks hooks_;
  rt_call::ProviderPort providers_;
  std::vector<std::unique_ptr<corba_agent::RawInPort>> in_ports_;
  std::vector<std::unique_ptr<corba_agent::RawOutPort>> out_ports_;
};

}  // namespace urs::bridge
