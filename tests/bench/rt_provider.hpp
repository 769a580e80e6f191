#pragma once
// The object an RTC's provider port offers, as a foreign consumer gets it: what the benches call
// through static stubs (corba_stub.hpp) to reach an RTC, or a space's service bound as one.

#include <stdexcept>
#include <string>

#include "urs/rt_call/provider_port.hpp"
#include "urs/rtc/naming.hpp"
#include "urs/rtc/orb.hpp"
#include "urs/rtc/tools.hpp"

namespace urs::bench {

// `path` names the RTC in the naming service (e.g. "jp1.host_cxt/Diagnostic0.rtc"), `port` its
// provider port; throws std::runtime_error when the port offers nothing (CORBA exceptions as raised).
inline CORBA::Object_ptr provider(urs::rtc::Orb& orb, urs::rtc::NamingClient& naming, const std::string& path,
                                  const std::string& port) {
  CORBA::Object_var object = naming.resolve(path);
  RTC::RTObject_var rtc = RTC::RTObject::_narrow(object);
  RTC::PortService_var service = urs::rtc::find_port(rtc, port);
  const auto offered = urs::rt_call::offered_by(service);
  if (offered.empty()) throw std::runtime_error(path + ":" + port + " offers nothing");
  return orb.string_to_object(offered.front().ior);
}

}  // namespace urs::bench
