#include "bridge_component.hpp"

namespace urs::bridge {

BridgeComponent::BridgeComponent(const std::string& bridge,
                                 const std::vector<const google::protobuf::Descriptor*>& in_types,
                                 const std::vector<const google::protobuf::Descriptor*>& out_types, Hooks hooks)
    : rtc::Component({"Bridge", "URSLink bridge between RT-Middleware and CAMUS", "1.0.0", "URSLink", "bridge"}),
      planet_peer_(bridge),
      hooks_(std::move(hooks)),
      providers_("providers") {
  for (std::size_t i = 0; i < in_types.size(); ++i) {
    in_ports_.push_back(std::make_unique<corba_agent::RawInPort>(
        "in" + std::to_string(i), *in_types[i],
        [this, i](const google::protobuf::Message& value) { hooks_.on_data(i, value); }));
  }
  for (std::size_t i = 0; i < out_types.size(); ++i) {
    out_ports_.push_back(std::make_unique<corba_agent::RawOutPort>("out" + std::to_string(i), *out_types[i]));
  }
}

rtc::PortBase& BridgeComponent::port_of_link(const std::string& link) {
  const auto hash = link.find('#');
  if (hash == std::string::npos) return providers_;
  const std::string ours = link.substr(hash + 1);
  for (auto& port : in_ports_) {
    if (port->short_name() == ours) return *port;
  }
  for (auto& port : out_ports_) {
    if (port->short_name() == ours) return *port;
  }
  throw std::logic_error("bridge: no port " + ours + " of its own");
}

RTC::ReturnCode_t BridgeComponent::handle_initialize() {
  add_port(providers_);
  for (auto& port : in_ports_) add_port(*port);
  for (auto& port : out_ports_) add_port(*port);
  declare_parameter("planet_peer", planet_peer_);
  return RTC::RTC_OK;
}

RTC::ReturnCode_t BridgeComponent::handle_activated(RTC::ExecutionContextHandle_t) {
  hooks_.set_active(true);
  return RTC::RTC_OK;
}

RTC::ReturnCode_t BridgeComponent::handle_deactivated(RTC::ExecutionContextHandle_t) {
  hooks_.set_active(false);
  return RTC::RTC_OK;
}

RTC::ReturnCode_t BridgeComponent::handle_finalize() {
  hooks_.set_active(false);
  return RTC::RTC_OK;
}

}  // namespace urs::bridge
