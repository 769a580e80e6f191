#include "urs/planet/status.hpp"

namespace urs::planet {

std::string_view status_name(Status status) {
  switch (status) {
    case Status::OK: return "OK";
    case Status::UNKNOWN_SERVICE: return "UNKNOWN_SERVICE";
    case Status::UNKNOWN_OPERATION: return "UNKNOWN_OPERATION";
    case Status::BAD_ARGUMENTS: return "BAD_ARGUMENTS";
    case Status::PROVIDER_GONE: return "PROVIDER_GONE";
    case Status::DEADLINE_EXCEEDED: return "DEADLINE_EXCEEDED";
    case Status::INTERNAL: return "INTERNAL";
    case Status::USER_EXCEPTION: return "USER_EXCEPTION";
    case Status::UNAVAILABLE: return "UNAVAILABLE";
    case Status::UNAUTHENTICATED: return "UNAUTHENTICATED";
    case Status::PAYLOAD_TOO_LARGE: return "PAYLOAD_TOO_LARGE";
    case Status::ALREADY_EXISTS: return "ALREADY_EXISTS";
    case Status::NOT_FOUND: return "NOT_FOUND";
    case Status::RESOURCE_EXHAUSTED: return "RESOURCE_EXHAUSTED";
    case Status::PERMISSION_DENIED: return "PERMISSION_DENIED";
    default: break;  // proto3 enums are open: values of a newer peer land here
  }
  return "UNKNOWN_STATUS";
}

}  // namespace urs::planet
