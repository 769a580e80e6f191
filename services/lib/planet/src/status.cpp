#include "urs/planet/status.hpp"

#include "urs/call/call.hpp"

namespace urs::planet {

std::string_view status_name(Status status) {
  // Planet's statuses are call::Status's numbers and names (checked in call_adapter.cpp); a number
  // of a newer peer's (proto3 enums are open) is named "UNKNOWN_STATUS" there.
  return call::status_name(static_cast<call::Status>(status));
}

}  // namespace urs::planet
