#pragma once
// W3C Trace Context (https://www.w3.org/TR/trace-context/, level 1): the `traceparent` one call
// carries from its first client through every hop, and the trace the calling thread works for.
//
// A hop that receives a call takes the caller's traceparent (TraceContext::parse; a value that is
// not valid starts a new trace, as the recommendation says), works for it inside a TraceScope (its
// log lines carry the trace id: urs/util/cli.hpp's formats), and sends on child(): the same trace
// id under a new parent id. A client with no current trace starts one (TraceContext::start).
//
// Threading: TraceContext is a value; the current trace is per thread.

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace urs::util {

struct TraceContext {
  std::array<uint8_t, 16> trace_id{};  // the whole call, end to end; never all zero
  std::array<uint8_t, 8> parent_id{};  // the span of the hop that sent it; never all zero
  uint8_t flags = 0;                   // trace-flags; bit 0: sampled

  // "00-<32 hex trace id>-<16 hex parent id>-<2 hex flags>" (55 characters, lowercase).
  std::string traceparent() const;
  // The 32 lowercase hex digits of trace_id (what log lines and `urs call` print).
  std::string trace_id_hex() const;

  // A traceparent value as it arrived (header, Planet field, CORBA service context, DDS field):
  // version 00 exactly as above; a later version's first four fields (anything after them must
  // start with '-'); nullopt for anything else: version ff, upper-case or missing hex digits, an
  // all-zero trace or parent id. Never allocates for a value longer than kMaxTraceparentBytes.
  static std::optional<TraceContext> parse(std::string_view text);
  // A new trace: random trace id and parent id, sampled.
  static TraceContext start();
  // The same trace and flags under a new random parent id: what this hop sends on.
  TraceContext child() const;

  friend bool operator==(const TraceContext& a, const TraceContext& b) {
    return a.trace_id == b.trace_id && a.parent_id == b.parent_id && a.flags == b.flags;
  }
};

// The longest traceparent value read (a version 00 value is 55); longer ones are refused.
inline constexpr size_t kMaxTraceparentBytes = 256;

// The trace the calling thread works for, or null outside every TraceScope.
const TraceContext* current_trace();

// The trace a hop sends on: the child of the current trace, or a new trace when there is none.
TraceContext outgoing_trace();

// Makes `trace` the calling thread's current trace until destroyed (then the one before it is
// current again). Scopes nest and are destroyed in reverse order on the thread that made them.
class TraceScope {
 public:
  explicit TraceScope(const TraceContext& trace);
  // A scope without a trace (nullopt) leaves the current one as it is.
  explicit TraceScope(const std::optional<TraceContext>& trace);
  ~TraceScope();
  TraceScope(const TraceScope&) = delete;
  TraceScope& operator=(const TraceScope&) = delete;

 private:
  std::optional<TraceContext> trace_;
  const TraceContext* previous_ = nullptr;
  bool entered_ = false;
};

// A command-line caller's report of its call's trace: "trace <id>" on stderr when `always` (the
// call failed, or the user asked) or stderr is a terminal, so that scripts reading the reply with
// 2>&1 get the reply alone (docs/operations.md, "Following one call").
void show_trace_id(const TraceContext& trace, bool always);

}  // namespace urs::util
