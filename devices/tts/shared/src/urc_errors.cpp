#include "urs/devices/urc_errors.hpp"

#include "URCTypes.pb.h"

namespace urs::devices {

agent::Outcome invalid_argument(const std::string& parameter, const std::string& reason) {
  auto error = std::make_shared<URC::InvalidArgument>();
  error->set_parameter(parameter);
  error->set_reason(reason);
  return agent::Outcome::raise(error, "InvalidArgument: " + parameter + ": " + reason);
}

agent::Outcome not_ready(const std::string& reason) {
  auto error = std::make_shared<URC::NotReady>();
  error->set_reason(reason);
  return agent::Outcome::raise(error, "NotReady: " + reason);
}

}  // namespace urs::devices
