#pragma once
// Outcome of a Planet call, shared by the client, the server and the service agents.

#include <string>
#include <string_view>
#include <utility>

#include "planet.pb.h"

namespace urs::planet {

using Status = ::urs::planet::Status;

// Human-readable, stable name of a status ("DEADLINE_EXCEEDED").
std::string_view status_name(Status status);

// The result of one call as the caller sees it. Per-message path: no exceptions.
struct CallResult {
  Status status = Status::OK;
  std::string message;         // reason when !ok()
  std::string payload;         // OK: serialized reply message; USER_EXCEPTION: serialized exception
  std::string exception_type;  // USER_EXCEPTION: full name of the exception message

  bool ok() const { return status == Status::OK; }

  static CallResult success(std::string payload) { return {Status::OK, {}, std::move(payload), {}}; }
  static CallResult error(Status status, std::string message) { return {status, std::move(message), {}, {}}; }
  static CallResult user_exception(std::string type, std::string payload, std::string message) {
    return {Status::USER_EXCEPTION, std::move(message), std::move(payload), std::move(type)};
  }
};

}  // namespace urs::planet
