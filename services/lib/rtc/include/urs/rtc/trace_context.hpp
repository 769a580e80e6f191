#pragma once
// W3C trace context over GIOP (docs/rtc.md, "Trace context"): every request this process sends
// carries the calling thread's trace (util::outgoing_trace: the child of its current trace, else a
// new one) in the service context kTraceServiceContext, whose context_data is the traceparent's 55
// ASCII bytes; every request it receives leaves the trace it carried (if valid) for the servant
// that answers it on that thread (incoming_trace). omniORB's interceptors do both; Orb's
// constructor installs them. Peers that do not know the service context ignore it (CORBA 3, 13.7).

#include <omniORB4/CORBA.h>

#include <optional>

#include "urs/util/trace.hpp"

namespace urs::rtc {

// "URS\0": the service context id of URSLink's traceparent.
inline constexpr CORBA::ULong kTraceServiceContext = 0x55525300;

// Installs the interceptors; once per process (later calls do nothing). Thread-safe.
void install_trace_interceptors();

// The valid trace the request the calling thread serves arrived with; nullopt when it carried
// none (or a value that is not a valid traceparent), or outside a request.
std::optional<util::TraceContext> incoming_trace();

}  // namespace urs::rtc
