#pragma once
// Where a hop reports each call it ends, for its metrics (urs::metrics::CallMetrics implements
// it; a hop without metrics has none and reports nothing).

#include <chrono>
#include <string>

#include "urs/call/call.hpp"

namespace urs::call {

class CallRecorder {
 public:
  virtual ~CallRecorder() = default;
  // One call ended at this hop with `status`, `elapsed` after it started here. `service` and
  // `operation` are names of this hop's catalog (what it routes, hosts or registered), never what
  // a peer sent unchecked: empty when the call named something the catalog does not hold (it is
  // counted as "other"). Thread-safe; never blocks for long, never throws.
  virtual void record(const std::string& service, const std::string& operation, Status status,
                      std::chrono::steady_clock::duration elapsed) noexcept = 0;
  // As record(), for a caller that cannot check the names (a client: the callee's catalog is
  // elsewhere). They count as given once a call to them ended in an outcome only the callee gives
  // (confirms()); until then, other outcomes of theirs count as "other".
  virtual void record_unchecked(const std::string& service, const std::string& operation, Status status,
                                std::chrono::steady_clock::duration elapsed) noexcept = 0;

  // Whether a call ending in `status` reached the service and operation it named: OK, USER_EXCEPTION,
  // PROVIDER_GONE, INTERNAL, ALREADY_EXISTS, NOT_FOUND, PERMISSION_DENIED. The others may come from
  // before the callee (no such service, a refused deadline, a lost connection, a full queue).
  static bool confirms(Status status) {
    switch (status) {
      case Status::OK:
      case Status::USER_EXCEPTION:
      case Status::PROVIDER_GONE:
      case Status::INTERNAL:
      case Status::ALREADY_EXISTS:
      case Status::NOT_FOUND:
      case Status::PERMISSION_DENIED:
        return true;
      default:
        return false;
    }
  }
};

}  // namespace urs::call
