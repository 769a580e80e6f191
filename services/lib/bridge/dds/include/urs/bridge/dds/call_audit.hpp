#pragma once
// CallAudit: the audit log of the calls other spaces make to this one (`dds.audit`,
// docs/federation.md "Audit log"): one JSON line per call served or refused, written when it is
// answered, to a file rotated by size (spdlog's rotating file sink: FILE, FILE.1 ... FILE.<files>).
// A line holds who called (space, name, whether the space was proven by a certificate), what
// (service, operation, oneway), its trace id, the outcome (status, and the refusal's reason when the bridge
// refused), when it arrived and how long it took; never a payload, a reply message or a secret.
//
// Threads: record() and the responders of recording() from any thread (one mutex inside the sink);
// each line is flushed when written. The responder returned by recording() keeps the log alive.

#include <chrono>
#include <cstddef>
#include <memory>
#include <optional>
#include <string>

#include "urs/call/call.hpp"

namespace spdlog {
class logger;
}

namespace urs::bridge {

struct AuditConfig {
  std::string file;                   // "" = no audit log
  std::size_t max_bytes = 10u << 20;  // a file is rotated once it would grow beyond this
  std::size_t files = 5;              // rotated files kept besides the current one
};

struct AuditEntry {
  std::chrono::system_clock::time_point time;  // when the call arrived
  call::Identity caller;
  std::string service;
  std::string operation;
  bool oneway = false;
  call::Status status = call::Status::OK;
  std::optional<std::string> refusal;  // the bridge's own reason, when it refused the call
  std::chrono::microseconds duration{0};
  std::string trace_id;  // the call's trace (32 hex digits, from its traceparent); empty: it came with none
};

// One entry as a JSON object on one line (no newline):
// {"time":"2026-11-28T09:20:15.123456Z","caller_space":"kr","caller":"dds:kr","space_verified":true,
//  "service":"rt.Diagnostic0","operation":"ping","oneway":false,"status":"OK","duration_us":812}
// with "reason" after "status" for a refusal of the bridge's own, and "trace_id" (32 hex digits)
// before "duration_us" for a call that came with a trace.
std::string audit_line(const AuditEntry& entry);

class CallAudit : public std::enable_shared_from_this<CallAudit> {
 public:
  // Opens (creates, appends to) config.file; throws std::runtime_error if it cannot.
  static std::shared_ptr<CallAudit> open(const AuditConfig& config);
  ~CallAudit();
  CallAudit(const CallAudit&) = delete;
  CallAudit& operator=(const CallAudit&) = delete;

  void record(const AuditEntry& entry);
  // Records `request` refused by the bridge itself: PERMISSION_DENIED with `reason`.
  void record_refusal(const call::Request& request, const std::string& reason);
  // A responder that records `request`'s outcome (and the time since `arrived`) when it answers,
  // then hands the reply to `responder`. A oneway request, whose outcome nobody learns, is recorded
  // at once as handed on (OK) and `responder` returned as it is.
  call::Responder recording(const call::Request& request, std::chrono::steady_clock::time_point arrived,
                            call::Responder responder);

 private:
  explicit CallAudit(std::shared_ptr<spdlog::logger> logger);
  std::shared_ptr<spdlog::logger> logger_;
};

}  // namespace urs::bridge
