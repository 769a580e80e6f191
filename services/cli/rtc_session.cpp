#include "rtc_session.hpp"

#include <algorithm>

#include "urs/rtc/tools.hpp"

namespace urs::cli::rtc_cli {

std::string normalize_path(const std::string& text) {
  const auto first = text.find_first_not_of('/');
  if (first == std::string::npos) return "";
  const auto last = text.find_last_not_of('/');
  return text.substr(first, last - first + 1);
}

// Naming paths hold no ':' in practice, host names included, so the last one splits.
PortAddress parse_port_address(const std::string& text) {
  const auto colon = text.rfind(':');
  PortAddress address;
  if (colon != std::string::npos) {
    address.path = normalize_path(text.substr(0, colon));
    address.port = text.substr(colon + 1);
  }
  if (address.path.empty() || address.port.empty()) {
    throw Failure(kUsage, "'" + text + "' is not PATH:PORT (e.g. myhost.host_cxt/Diagnostic0.rtc:diagnostic)");
  }
  return address;
}

// A dead process behind a stale binding gives TRANSIENT or OBJECT_NOT_EXIST, a hung one TIMEOUT:
// all of them mean the component cannot be reached.
std::string reason(const CORBA::SystemException& e, CORBA::Object_ptr target) {
  const bool unreachable = CORBA::TRANSIENT::_downcast(&e) || CORBA::COMM_FAILURE::_downcast(&e) ||
                           CORBA::OBJECT_NOT_EXIST::_downcast(&e) || CORBA::TIMEOUT::_downcast(&e);
  if (!unreachable) return rtc::describe(e);
  // A servant lets the system exceptions of its own outgoing calls through to its caller: ask
  // the object itself (answered by its ORB, not by its code) whether it is there.
  if (!CORBA::is_nil(target) && rtc::liveness(target) == rtc::Liveness::kAlive) {
    return "reported an error (" + rtc::describe(e) + ")";
  }
  return "unreachable (" + rtc::describe(e) + ")";
}

std::string short_port_name(const std::string& name) {
  const auto dot = name.find('.');
  return dot == std::string::npos ? name : name.substr(dot + 1);
}

namespace {

rtc::OrbOptions orb_options(std::chrono::milliseconds call_timeout) {
  rtc::OrbOptions options;
  options.call_timeout = call_timeout;
  options.connect_timeout = std::min(call_timeout, options.connect_timeout);
  return options;
}

}  // namespace

Session::Session(const std::string& naming, std::chrono::milliseconds call_timeout)
    : orb_(orb_options(call_timeout)), naming_(orb_, naming) {}

CORBA::Object_ptr Session::resolve(const std::string& path) {
  try {
    return naming_.resolve(path);
  } catch (const rtc::NamingUnreachable&) {
    throw;
  } catch (const rtc::NamingError& e) {
    throw Failure(kFailed, e.what());
  }
}

RTC::RTObject_ptr Session::component(const std::string& path) {
  CORBA::Object_var object = resolve(path);
  RTC::RTObject_var target = calling(path, [&] { return RTC::RTObject::_narrow(object); });
  if (CORBA::is_nil(target)) throw Failure(kFailed, path + ": not an RT-Component");
  return target._retn();
}

RTC::PortService_ptr Session::port(const PortAddress& address) {
  RTC::RTObject_var target = component(address.path);
  RTC::PortService_var port = calling(
      address.path, [&] { return rtc::find_port(target, address.port); }, target);
  if (CORBA::is_nil(port)) {
    std::string names;
    calling(
        address.path,
        [&] {
          RTC::PortServiceList_var ports = target->get_ports();
          for (CORBA::ULong i = 0; i < ports->length(); ++i) {
            RTC::PortProfile_var profile = ports[i]->get_port_profile();
            names += (names.empty() ? "" : ", ") + short_port_name(profile->name.in());
          }
        },
        target);
    throw Failure(kFailed,
                  address.path + ": no port '" + address.port + "' (ports: " + (names.empty() ? "none" : names) + ")");
  }
  return port._retn();
}

}  // namespace urs::cli::rtc_cli
