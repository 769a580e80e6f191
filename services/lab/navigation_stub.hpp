#pragma once
// The robot's Navigation provider port called as the papers' RT consumer called it: through the
// omniORB stubs compiled from Navigation.idl (static invocation), the object reference got from
// the port like any consumer gets it. A file of its own: the stubs and the Protobuf classes of one
// IDL share C++ names (idl/CMakeLists.txt), so this side reads and fills the Protobuf messages of
// RemoteService by field name.

#include <memory>
#include <string>

#include "remote_service.hpp"

namespace urs::lab {

// The URC::Navigation provider port "PATH:PORT" in the naming service. Operations: moveTo,
// setSpeed, getPosition, stop, _get_state. Throws std::runtime_error if the port cannot be found
// or provides no URC::Navigation.
std::unique_ptr<RemoteService> rt_navigation_stub(rtc::Orb& orb, rtc::NamingClient& naming,
                                                  const std::string& port_address);

}  // namespace urs::lab
