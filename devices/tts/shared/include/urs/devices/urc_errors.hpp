#pragma once
// The URC exceptions (idl/urc/URCTypes.idl) as agent outcomes, so that every device raises them
// the same way.

#include <string>

#include "urs/agent/agent.hpp"

namespace urs::devices {

agent::Outcome invalid_argument(const std::string& parameter, const std::string& reason);
agent::Outcome not_ready(const std::string& reason);

}  // namespace urs::devices
