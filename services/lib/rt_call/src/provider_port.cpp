#include "urs/rt_call/provider_port.hpp"

#include <cstdint>
#include <cstdlib>
#include <set>

namespace urs::rt_call {

std::string ior_type_id(const std::string& ior) {
  if (ior.size() < 4 || ior.compare(0, 4, "IOR:") != 0 || ior.size() % 2 != 0) return "";
  std::string bytes;
  for (std::size_t i = 4; i + 1 < ior.size(); i += 2) {
    const std::string pair = ior.substr(i, 2);
    char* end = nullptr;
    const long value = std::strtol(pair.c_str(), &end, 16);
    if (end != pair.c_str() + 2) return "";
    bytes.push_back(static_cast<char>(value));
  }
  // CDR encapsulation: byte-order octet, padding to 4, then the type ID as a CDR string.
  if (bytes.size() < 8) return "";
  const bool little = bytes[0] != 0;
  uint32_t length = 0;
  for (int i = 0; i < 4; ++i) {
    const auto byte = static_cast<uint8_t>(bytes[4 + i]);
    length |= little ? uint32_t(byte) << (8 * i) : uint32_t(byte) << (8 * (3 - i));
  }
  if (length == 0 || 8 + length > bytes.size()) return "";
  return bytes.substr(8, length - 1);  // without the terminating NUL
}

std::vector<ProvidedInterface> provided_interfaces(const SDOPackage::NVList& properties) {
  std::vector<ProvidedInterface> found;
  std::vector<ProvidedInterface> old_style;
  for (CORBA::ULong i = 0; i < properties.length(); ++i) {
    const std::string key = properties[i].name.in();
    const char* value = nullptr;
    if (!(properties[i].value >>= value) || value == nullptr) continue;
    const std::string ior = value;
    if (ior.compare(0, 4, "IOR:") != 0) continue;
    ProvidedInterface entry;
    entry.key = key;
    entry.ior = ior;
    const auto port_at = key.find(".port.");
    const auto provided_at = key.find(".provided.");
    if (port_at != std::string::npos && provided_at != std::string::npos && port_at < provided_at) {
      entry.component = key.substr(0, port_at);
      entry.port = key.substr(port_at + 6, provided_at - port_at - 6);
      const std::string rest = key.substr(provided_at + 10);  // "<type>.<name>"
      const auto dot = rest.rfind('.');
      if (dot == std::string::npos) continue;
      entry.type_name = rest.substr(0, dot);
      entry.instance_name = rest.substr(dot + 1);
      found.push_back(std::move(entry));
    } else if (key.compare(0, 5, "port.") == 0) {
      const std::string rest = key.substr(5);
      const auto dot = rest.rfind('.');
      if (dot == std::string::npos) continue;
      entry.type_name = rest.substr(0, dot);
      entry.instance_name = rest.substr(dot + 1);
      old_style.push_back(std::move(entry));
    }
  }
  std::set<std::string> seen;
  for (const auto& entry : found) seen.insert(entry.ior);
  for (auto& entry : old_style) {
    if (seen.insert(entry.ior).second) found.push_back(std::move(entry));
  }
  return found;
}

std::vector<ProvidedInterface> offered_by(RTC::PortService_ptr port) {
  RTC::ConnectorProfile profile;
  profile.name = CORBA::string_dup("urs-offered-by");
  profile.connector_id = CORBA::string_dup("");
  profile.ports.length(1);
  profile.ports[0] = RTC::PortService::_duplicate(port);
  if (port->connect(profile) != RTC::RTC_OK) return {};
  port->disconnect(profile.connector_id.in());
  return provided_interfaces(profile.properties);
}

ProviderPort::ProviderPort(std::string name) : PortBase(std::move(name), "CorbaPort") {}

ProviderPort::~ProviderPort() = default;

std::map<std::string, std::vector<ProvidedInterface>> ProviderPort::connections() const {
  std::lock_guard lock(mutex_);
  return connections_;
}

RTC::ReturnCode_t ProviderPort::publish_interfaces(RTC::ConnectorProfile&) { return RTC::RTC_OK; }

RTC::ReturnCode_t ProviderPort::subscribe_interfaces(const RTC::ConnectorProfile& profile) {
  auto interfaces = provided_interfaces(profile.properties);
  std::lock_guard lock(mutex_);
  connections_[profile.connector_id.in()] = std::move(interfaces);
  return RTC::RTC_OK;
}

void ProviderPort::unsubscribe_interfaces(const RTC::ConnectorProfile& profile) {
  std::lock_guard lock(mutex_);
  connections_.erase(profile.connector_id.in());
}

}  // namespace urs::rt_call
