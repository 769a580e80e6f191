#include "bridge_component.hpp"

namespace urs::bridge {

BridgeComponent::BridgeComponent(const BridgeConfig& config, const InterfaceCatalog& catalog, Hooks hooks)
    : rtc::Component({"Bridge", "URSLink bridge between RT-Middleware and CAMUS", "1.0.0", "URSLink", "bridge"}),
      planet_peer_(config.name),
      hooks_(std::move(hooks)),
      providers_("providers") {
  for (std::size_t i = 0; i < config.data_to_camus.size(); ++i) {
    const google::protobuf::Descriptor* type = catalog.find_message(config.data_to_camus[i].type);
    in_ports_.push_back(std::make_unique<corba_agent::RawInPort>(
        "in" + std::to_string(i), *type, [this, i](const google::protobuf::Message& value) { hooks_.on_data(i, value); }));
  }
  for (std::size_t i = 0; i < config.events_to_rt.size(); ++i) {
    const google::protobuf::Descriptor* type = catalog.find_message(config.events_to_rt[i].type);
    out_ports_.push_back(std::make_unique<corba_agent::RawOutPort>("out" + std::to_string(i), *type));
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
