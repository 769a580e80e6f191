#pragma once
// Invocation routing: a Request goes to a built-in service or to a session that provides the
// service, with a fresh server-side call id and a deadline; the Reply goes back to the caller
// under the caller's call id. A Request forwarded to a provider carries its caller
// (Request.caller: the name and role this server authenticated), which only the server sets.
//
// Which provider (a service may have several, Registry): the one with the fewest calls pending,
// among those not suspected of being stuck; of equals, the one picked least recently. A provider
// is suspected once a call forwarded to it passed its deadline without any reply from it since
// that call was sent (a paused or hung process); its next reply clears it. When every provider
// is suspected, the fewest pending wins all the same. A call is forwarded once: one whose
// provider's connection closes before the call could be queued to it goes to the next provider
// (nobody received it); one already forwarded is never sent again (it may have run), so it ends
// with the provider's reply, DEADLINE_EXCEEDED or PROVIDER_GONE.
//
// Guarantees: every accepted non-oneway call is answered exactly once (the provider's reply,
// DEADLINE_EXCEEDED, PROVIDER_GONE, or UNAVAILABLE at shutdown); a reply that comes too late is
// dropped and logged at debug level. Oneway requests are forwarded without bookkeeping.
//
// Trace context: a Request goes on with the caller's traceparent under this server's own parent
// id (TraceContext::child), or with a new trace when it carries none that is valid.
//
// Refusals, each a Reply with the limit or rule named (oneways are dropped and logged instead):
//  - BAD_ARGUMENTS: deadline_ms over max_deadline_ms; a call_id already pending on the same
//    connection (the first call goes on; its own Reply comes later under the same id);
//  - PERMISSION_DENIED: the caller's role is below what the service and operation need
//    (LocalServices::required_role); the Request names its caller (Request.caller is the server's);
//  - RESOURCE_EXHAUSTED: the connection already has max_pending_calls_per_session calls
//    pending, or the caller's credential is over its fair share of max_pending_calls
//    (planet::FairShare: max_pending_calls_per_credential; a reserved_percent of the server's
//    calls is kept for sam and operator sessions and the server's own calls).
//
// Threading: thread-safe; never blocks (Session::send queues). Deadlines run on a Scheduler (one
// timer thread), so a slow provider holds no thread.

#include <chrono>
#include <cstdint>
#include <functional>
#include <mutex>
#include <optional>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "planet.pb.h"
#include "urs/call/recorder.hpp"
#include "urs/camus_server/registry.hpp"
#include "urs/camus_server/timer.hpp"
#include "urs/planet/fair_share.hpp"
#include "urs/planet/server.hpp"
#include "urs/planet/status.hpp"
#include "urs/util/trace.hpp"

namespace urs::camus_server {

// Who is calling.
struct Caller {
  planet::SessionPtr session;            // null for callers inside the server (task runs)
  std::string identity;                  // the session's authenticated name, or e.g. "task:square-path/r3"
  planet::Role role = planet::OPERATOR;  // what it may do (the server's own callers may do all)
  uint64_t session_id() const { return session ? session->id() : 0; }
  // Whose share its calls count in: the credential; privileged for sam, operator and the server.
  planet::ShareHolder holder() const { return {identity, !session || role >= planet::SAM}; }
  // The caller of a Request frame from `session`.
  static Caller of(const planet::SessionPtr& session);
};

// Runs exactly once with the outcome of a call.
using Completion = std::function<void(planet::CallResult)>;

// Services implemented inside the server (the registry and the service container).
class LocalServices {
 public:
  virtual ~LocalServices() = default;
  virtual bool serves(const std::string& service) const = 0;
  // The least role that may call `operation` of the local `service`.
  virtual planet::Role required_role(const std::string& service, const std::string& operation) const = 0;
  // Never blocks the caller. Calls `done` exactly once, on any thread, possibly before returning;
  // for oneway requests `done` may be ignored.
  virtual void dispatch(const Caller& caller, const planet::Request& request, Completion done) = 0;
};

struct RouterOptions {
  std::string space;
  std::chrono::milliseconds default_deadline{10000};
  uint64_t max_deadline_ms = 86'400'000;           // a larger Request.deadline_ms is refused
  size_t max_pending_calls = 10000;                // calls waiting for a reply, server-wide
  size_t max_pending_calls_per_credential = 2500;  // of one credential's connections
  size_t max_pending_calls_per_session = 1000;     // of one connection
  unsigned reserved_percent = 20;                  // of max_pending_calls, kept for sam, operator, server
  // Where the calls of sessions are counted when they end (metrics), by the registry's names for
  // them; null: not counted. Outlives the router.
  call::CallRecorder* calls = nullptr;
};

class Router {
 public:
  // `local` and `timers` must outlive the router, and `local` must have answered (or dropped)
  // every dispatched call before the router is destroyed.
  Router(RouterOptions options, const Registry& registry, LocalServices& local, Scheduler& timers);
  ~Router();  // shutdown()
  Router(const Router&) = delete;
  Router& operator=(const Router&) = delete;

  // A Request frame from `session`; the outcome is sent back as a Reply frame under the
  // caller's call_id.
  void on_request(const planet::SessionPtr& session, planet::Request request);
  // A Reply frame from `session` (a provider answering a forwarded call).
  void on_reply(const planet::Session& session, planet::Reply reply);
  // A call from any caller; `done` runs exactly once unless the request is oneway.
  void call(const Caller& caller, planet::Request request, Completion done);
  // Fails calls pending at the closed session (PROVIDER_GONE) and forgets those it made.
  void on_session_closed(uint64_t session_id);
  // The calls pending at the provider connection `session_id`, and whether it is suspected
  // (see above): for listings and tests.
  size_t pending_at(uint64_t session_id) const;
  bool suspected(uint64_t session_id) const;
  // Answers every pending call UNAVAILABLE; later calls are refused the same way. Idempotent.
  void shutdown();

  size_t pending() const;
  // The refusals so far, by the limit that refused (max_deadline_ms, max_pending_calls_per_session,
  // max_pending_calls_per_credential, max_pending_calls).
  std::vector<std::pair<std::string, uint64_t>> refusals() const;

 private:
  struct Pending {
    uint64_t caller_session = 0;
    planet::ShareHolder caller;   // whose share of max_pending_calls it holds
    uint64_t caller_call_id = 0;  // with caller_session: the caller's own id (Request frames only)
    bool from_frame = false;
    Completion done;
    std::string service;
    std::string operation;
    uint64_t provider_session = 0;  // 0 for built-ins
    std::string provider;
    uint64_t deadline_ms = 0;
    Scheduler::TimerId timer = 0;
    uint64_t sent_tick = 0;  // the provider's reply tick when it was forwarded
  };
  using PendingMap = std::unordered_map<uint64_t, Pending>;
  // A provider connection with calls pending or a past: what choosing among providers weighs.
  struct ProviderLoad {
    size_t pending = 0;
    uint64_t last_pick = 0;   // pick_tick_ when it was last chosen
    uint64_t reply_tick = 0;  // counts its replies
    bool suspected = false;
  };
  // The provider of `route` a call goes to, skipping the connections in `tried`; null if none is
  // left. Mutex held.
  const RouteProvider* pick_locked(const Route& route, const std::vector<uint64_t>& tried);
  // A call to `provider_session` ended (`pending`: it was counted) or was never delivered;
  // `closed`: the connection is known closed, so its entry goes once nothing is pending there.
  void release_locked(uint64_t provider_session, bool pending, bool closed);
  // `caller_call_id` is set for Request frames (checked for duplicates and per-session limits).
  void route(const Caller& caller, planet::Request request, Completion done, std::optional<uint64_t> caller_call_id);
  void complete(uint64_t call_id, planet::CallResult result);
  void expire(uint64_t call_id);
  // Removes the entry and its caller index; returns its completion. Mutex held.
  Completion erase_locked(PendingMap::iterator it);
  // `done`, which also counts the call in options_.calls (if any) and logs its end under `trace` at
  // debug level.
  Completion recorded(const planet::Request& request, const Caller& caller, const util::TraceContext& trace,
                      Completion done) const;

  const RouterOptions options_;
  const Registry& registry_;
  LocalServices& local_;
  Scheduler& timers_;
  mutable std::mutex mutex_;
  PendingMap pending_;
  planet::FairShare shares_;  // pending calls by caller credential
  // Connection -> (caller's call id -> server call id) of the calls it has pending.
  std::unordered_map<uint64_t, std::unordered_map<uint64_t, uint64_t>> by_caller_;
  // Provider connection -> its load; an entry lives while the connection is open and has been
  // chosen (erased in on_session_closed).
  std::unordered_map<uint64_t, ProviderLoad> providers_;
  uint64_t pick_tick_ = 0;
  uint64_t next_call_id_ = 1;
  bool shut_down_ = false;
  planet::Refusals refusals_;  // by the router's own limits (shares_ counts its own)
};

}  // namespace urs::camus_server
