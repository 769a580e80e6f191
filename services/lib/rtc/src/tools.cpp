#include "urs/rtc/tools.hpp"

#include "urs/rtc/nvlist.hpp"

namespace urs::rtc {

const char* return_code_name(RTC::ReturnCode_t code) {
  switch (code) {
    case RTC::RTC_OK: return "RTC_OK";
    case RTC::RTC_ERROR: return "RTC_ERROR";
    case RTC::BAD_PARAMETER: return "BAD_PARAMETER";
    case RTC::UNSUPPORTED: return "UNSUPPORTED";
    case RTC::OUT_OF_RESOURCES: return "OUT_OF_RESOURCES";
    case RTC::PRECONDITION_NOT_MET: return "PRECONDITION_NOT_MET";
    default: return "UNKNOWN_RETURN_CODE";
  }
}

const char* state_name(RTC::LifeCycleState state) {
  switch (state) {
    case RTC::CREATED: return "Created";
    case RTC::INACTIVE: return "Inactive";
    case RTC::ACTIVE: return "Active";
    case RTC::ERROR: return "Error";
    default: return "Unknown";
  }
}

RTC::LifeCycleState component_state(RTC::RTObject_ptr rtc) {
  RTC::ExecutionContextList_var contexts = rtc->get_owned_contexts();
  if (contexts->length() == 0 || CORBA::is_nil(contexts[0])) return RTC::CREATED;
  return contexts[0]->get_component_state(rtc);
}

RTC::PortService_ptr find_port(RTC::RTObject_ptr rtc, const std::string& name) {
  RTC::PortServiceList_var ports = rtc->get_ports();
  for (CORBA::ULong i = 0; i < ports->length(); ++i) {
    RTC::PortProfile_var profile = ports[i]->get_port_profile();
    const std::string full = profile->name.in();
    const auto dot = full.find('.');
    if (full == name || (dot != std::string::npos && full.substr(dot + 1) == name)) {
      return RTC::PortService::_duplicate(ports[i]);
    }
  }
  return RTC::PortService::_nil();
}

namespace {

// "<instance>.port.<port>" for a port profile named "<instance>.<port>".
std::string key_prefix(const RTC::PortProfile& port) {
  const std::string name = port.name.in();
  const auto dot = name.find('.');
  if (dot == std::string::npos) return "port." + name;
  return name.substr(0, dot) + ".port." + name.substr(dot + 1);
}

// For each required interface that exactly one provided interface of the same type among the
// ports can satisfy, names that provider in the new-style "required" key, so that the consumer
// finds it whatever the two interface instance names are.
void map_required_interfaces(const std::vector<RTC::PortProfile>& ports, SDOPackage::NVList& properties) {
  for (const RTC::PortProfile& consumer : ports) {
    for (CORBA::ULong i = 0; i < consumer.interfaces.length(); ++i) {
      const RTC::PortInterfaceProfile& required = consumer.interfaces[i];
      if (required.polarity != RTC::REQUIRED) continue;
      const std::string type = required.type_name.in();
      const std::string key = key_prefix(consumer) + ".required." + type + "." + required.instance_name.in();
      std::vector<std::string> providers;
      for (const RTC::PortProfile& provider : ports) {
        if (&provider == &consumer) continue;
        for (CORBA::ULong j = 0; j < provider.interfaces.length(); ++j) {
          const RTC::PortInterfaceProfile& offered = provider.interfaces[j];
          if (offered.polarity == RTC::PROVIDED && type == offered.type_name.in()) {
            providers.push_back(key_prefix(provider) + ".provided." + type + "." + offered.instance_name.in());
          }
        }
      }
      if (providers.size() == 1 && !nv_has(properties, key)) nv_set(properties, key, providers.front());
    }
  }
}

}  // namespace

SDOPackage::NVList connector_properties(const std::vector<RTC::PortProfile>& ports, const SDOPackage::NVList& extra) {
  SDOPackage::NVList properties = extra;
  map_required_interfaces(ports, properties);
  bool data = false;
  std::string data_type;
  for (const RTC::PortProfile& port : ports) {
    const auto type = nv_string(port.properties, "port.port_type");
    if (type == "DataOutPort" || type == "DataInPort") data = true;
    const auto port_data_type = nv_string(port.properties, "dataport.data_type");
    if (port_data_type && (data_type.empty() || type == "DataOutPort")) data_type = *port_data_type;
  }
  if (!data) return properties;
  const std::pair<const char*, std::string> defaults[] = {
      {"dataport.interface_type", "corba_cdr"},
      {"dataport.dataflow_type", "push"},
      {"dataport.subscription_type", "flush"},
      {"dataport.serializer.cdr.endian", "little"},
      {"dataport.data_type", data_type},
  };
  for (const auto& [name, value] : defaults) {
    if (!nv_has(properties, name) && !value.empty()) nv_set(properties, name, value);
  }
  return properties;
}

Connection connect_ports(const std::vector<RTC::PortService_ptr>& ports, const std::string& name,
                         const SDOPackage::NVList& extra, const std::string& id) {
  std::vector<RTC::PortProfile> profiles;
  RTC::ConnectorProfile profile;
  profile.name = CORBA::string_dup(name.c_str());
  profile.connector_id = CORBA::string_dup(id.c_str());
  profile.ports.length(static_cast<CORBA::ULong>(ports.size()));
  for (CORBA::ULong i = 0; i < ports.size(); ++i) {
    profile.ports[i] = RTC::PortService::_duplicate(ports[i]);
    RTC::PortProfile_var port = ports[i]->get_port_profile();
    profiles.push_back(port.in());
  }
  profile.properties = connector_properties(profiles, extra);
  Connection result;
  result.code = ports.at(0)->connect(profile);
  result.profile = profile;
  return result;
}

int disconnect_ports(RTC::PortService_ptr a, RTC::PortService_ptr b) {
  RTC::ConnectorProfileList_var connectors = a->get_connector_profiles();
  int count = 0;
  for (CORBA::ULong i = 0; i < connectors->length(); ++i) {
    const RTC::ConnectorProfile& connector = connectors[i];
    for (CORBA::ULong j = 0; j < connector.ports.length(); ++j) {
      if (connector.ports[j]->_is_equivalent(b)) {
        if (a->disconnect(connector.connector_id) == RTC::RTC_OK) ++count;
        break;
      }
    }
  }
  return count;
}

}  // namespace urs::rtc
