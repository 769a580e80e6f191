#include "urs/rtc/tools.hpp"

#include <algorithm>

#include "urs/rtc/nvlist.hpp"

namespace urs::rtc {

const char* return_code_name(RTC::ReturnCode_t code) {
  switch (code) {
    case RTC::RTC_OK:
      return "RTC_OK";
    case RTC::RTC_ERROR:
      return "RTC_ERROR";
    case RTC::BAD_PARAMETER:
      return "BAD_PARAMETER";
    case RTC::UNSUPPORTED:
      return "UNSUPPORTED";
    case RTC::OUT_OF_RESOURCES:
      return "OUT_OF_RESOURCES";
    case RTC::PRECONDITION_NOT_MET:
      return "PRECONDITION_NOT_MET";
    default:
      return "UNKNOWN_RETURN_CODE";
  }
}

const char* state_name(RTC::LifeCycleState state) {
  switch (state) {
    case RTC::CREATED:
      return "Created";
    case RTC::INACTIVE:
      return "Inactive";
    case RTC::ACTIVE:
      return "Active";
    case RTC::ERROR:
      return "Error";
    default:
      return "Unknown";
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
      {"dataport.interface_type", "corba_cdr"}, {"dataport.dataflow_type", "push"},
      {"dataport.subscription_type", "flush"},  {"dataport.serializer.cdr.endian", "little"},
      {"dataport.data_type", data_type},
  };
  for (const auto& [name, value] : defaults) {
    if (!nv_has(properties, name) && !value.empty()) nv_set(properties, name, value);
  }
  return properties;
}

namespace {

// "URC::Navigation", "IDL:URC/Navigation:1.0", "Navigation" -> their name components.
std::vector<std::string> type_path(std::string name) {
  if (name.rfind("IDL:", 0) == 0) {
    name = name.substr(4);
    const auto version = name.rfind(':');
    if (version != std::string::npos) name.resize(version);
  }
  std::vector<std::string> parts;
  std::size_t start = 0;
  while (start <= name.size()) {
    const auto slash = name.find('/', start);
    const auto colons = name.find("::", start);
    const auto end = std::min(slash, colons);
    parts.push_back(name.substr(start, end - start));
    if (end == std::string::npos) break;
    start = end + (end == colons ? 2 : 1);
  }
  return parts;
}

std::string interfaces_of(const RTC::PortProfile& port, RTC::PortInterfacePolarity polarity) {
  std::string out;
  for (CORBA::ULong i = 0; i < port.interfaces.length(); ++i) {
    if (port.interfaces[i].polarity == polarity)
      out += (out.empty() ? "" : ", ") + std::string(port.interfaces[i].type_name.in());
  }
  return out.empty() ? "nothing" : out;
}

// Whether some interface `consumer` requires is provided, by type, by `provider`.
bool meets(const RTC::PortProfile& consumer, const RTC::PortProfile& provider) {
  for (CORBA::ULong i = 0; i < consumer.interfaces.length(); ++i) {
    if (consumer.interfaces[i].polarity != RTC::REQUIRED) continue;
    for (CORBA::ULong j = 0; j < provider.interfaces.length(); ++j) {
      if (provider.interfaces[j].polarity == RTC::PROVIDED &&
          same_type_name(consumer.interfaces[i].type_name.in(), provider.interfaces[j].type_name.in())) {
        return true;
      }
    }
  }
  return false;
}

bool requires_any(const RTC::PortProfile& port) {
  for (CORBA::ULong i = 0; i < port.interfaces.length(); ++i) {
    if (port.interfaces[i].polarity == RTC::REQUIRED) return true;
  }
  return false;
}

}  // namespace

bool same_type_name(const std::string& a, const std::string& b) {
  const std::vector<std::string> x = type_path(a);
  const std::vector<std::string> y = type_path(b);
  const auto& shorter = x.size() <= y.size() ? x : y;
  const auto& longer = x.size() <= y.size() ? y : x;
  return !shorter.empty() && std::equal(shorter.rbegin(), shorter.rend(), longer.rbegin());
}

std::string connection_mismatch(const RTC::PortProfile& a, const RTC::PortProfile& b) {
  const std::string a_name = a.name.in();
  const std::string b_name = b.name.in();
  const std::string a_kind = nv_string(a.properties, "port.port_type").value_or("");
  const std::string b_kind = nv_string(b.properties, "port.port_type").value_or("");
  const auto is_data = [](const std::string& kind) { return kind == "DataInPort" || kind == "DataOutPort"; };
  const auto known = [&](const std::string& kind) { return kind == "CorbaPort" || is_data(kind); };
  if (!known(a_kind) || !known(b_kind)) return {};
  if (is_data(a_kind) != is_data(b_kind)) {
    return a_name + " is a " + a_kind + " and " + b_name + " a " + b_kind +
           ": a data port connects to a data port, a service port to a service port";
  }
  if (is_data(a_kind)) {
    if (a_kind == b_kind)
      return a_name + " and " + b_name + " are both " + a_kind + "s: one must be an out port, the other an in port";
    const auto a_type = nv_string(a.properties, "dataport.data_type");
    const auto b_type = nv_string(b.properties, "dataport.data_type");
    if (a_type && b_type && !same_type_name(*a_type, *b_type)) {
      return a_name + " carries " + *a_type + " but " + b_name + " carries " + *b_type;
    }
    return {};
  }
  // A port that declares no interface (e.g. the bridge's `providers`, which takes any provider)
  // leaves nothing to compare.
  if (a.interfaces.length() == 0 || b.interfaces.length() == 0) return {};
  if (!requires_any(a) && !requires_any(b)) {
    return "neither " + a_name + " nor " + b_name + " requires an interface (" + a_name + " provides " +
           interfaces_of(a, RTC::PROVIDED) + ", " + b_name + " provides " + interfaces_of(b, RTC::PROVIDED) + ")";
  }
  if (meets(a, b) || meets(b, a)) return {};
  const RTC::PortProfile& consumer = requires_any(a) ? a : b;
  const RTC::PortProfile& other = requires_any(a) ? b : a;
  return std::string(consumer.name.in()) + " requires " + interfaces_of(consumer, RTC::REQUIRED) + " but " +
         other.name.in() + " provides " + interfaces_of(other, RTC::PROVIDED);
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
