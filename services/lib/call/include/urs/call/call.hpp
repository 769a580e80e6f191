#pragma once
// The neutral call model: what one call is, whatever middleware carried it (Planet, DDS, CORBA).
//
// A middleware adapter turns what arrived on its wire into a Request and a Responder, and turns
// the Reply it gets back into its wire's answer; service agents, the agent host, the DDS link and
// the forwarding proxies see only these types. The Planet library converts to and from them
// (urs/planet/call_adapter.hpp); the DDS link carries Status as its number.

#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <utility>

namespace urs::call {

// Typed outcome of a call. The numbers are those of the Planet protocol's Status (the Planet
// library checks it at compile time) and of the DDS CallReply.status: never renumber.
enum class Status : std::int32_t {
  OK = 0,
  UNKNOWN_SERVICE = 1,      // no service of that name
  UNKNOWN_OPERATION = 2,    // the service's interface has no such operation
  BAD_ARGUMENTS = 3,        // the payload is not the operation's request, or a value is out of range
  PROVIDER_GONE = 4,        // the provider disconnected or died before replying
  DEADLINE_EXCEEDED = 5,    // no reply within the call's deadline
  INTERNAL = 6,             // a bug or unexpected failure in the callee; the message says what
  USER_EXCEPTION = 7,       // the operation raised an exception its interface declares
  UNAVAILABLE = 8,          // the callee cannot be reached now, or is shutting down
  UNAUTHENTICATED = 9,      // the caller's credential is wrong or missing
  PAYLOAD_TOO_LARGE = 10,   // over the receiver's message size limit
  ALREADY_EXISTS = 11,      // e.g. a service name another provider owns
  NOT_FOUND = 12,           // e.g. a context key or task that does not exist
  RESOURCE_EXHAUSTED = 13,  // a queue or quota is full
  PERMISSION_DENIED = 14,   // the caller's role may not do this
};

// The highest number of Status; numbers 0..kLastStatus are all statuses.
inline constexpr std::int32_t kLastStatus = static_cast<std::int32_t>(Status::PERMISSION_DENIED);

// Human-readable, stable name of a status ("DEADLINE_EXCEEDED"); "UNKNOWN_STATUS" for a number
// outside the set.
std::string_view status_name(Status status);

// The status with that number; nullopt for a number outside the set (a peer's number is checked
// with this before it is used).
std::optional<Status> status_from_number(std::int64_t number);

constexpr std::int32_t status_number(Status status) { return static_cast<std::int32_t>(status); }

// The caller of a call as the receiving adapter verified it: the authenticated name of a Planet
// session and the role its credential grants, the space of the DDS participant that sent it.
// Never what a peer declared about itself. Empty fields: the adapter does not know (a call made
// inside this process).
struct Identity {
  std::string space;  // the caller's space; empty: this space
  std::string name;   // e.g. the credential's name "sam-robot1", or "dds:<space>" for another space's bridge
  std::string role;   // the granted role, e.g. "client", "sam", "operator" (Planet); "member" (DDS, space proven by
                      // its certificate) or "bridge" (DDS, space only declared)

  bool known() const { return !name.empty(); }
};

// One call as it arrives.
struct Request {
  using Clock = std::chrono::steady_clock;

  std::string service;                                    // e.g. "robot1.navigation"
  std::string operation;                                  // a method of the service's interface, e.g. "moveTo"
  std::string payload;                                    // the serialized request message of the operation
  Clock::time_point deadline = Clock::time_point::max();  // after this the caller has given up; max: none
  Identity caller;
  bool oneway = false;      // nothing is sent back
  std::string traceparent;  // the W3C trace context it came with (urs/util/trace.hpp); empty: none

  bool has_deadline() const { return deadline != Clock::time_point::max(); }
};

// The outcome of one call as the caller sees it. Per-message path: no exceptions.
struct Reply {
  Status status = Status::OK;
  std::string message;         // reason when !ok()
  std::string payload;         // OK: serialized reply message; USER_EXCEPTION: serialized exception
  std::string exception_type;  // USER_EXCEPTION: full name of the exception message

  bool ok() const { return status == Status::OK; }

  static Reply success(std::string payload) { return {Status::OK, {}, std::move(payload), {}}; }
  static Reply error(Status status, std::string message) { return {status, std::move(message), {}, {}}; }
  static Reply user_exception(std::string type, std::string payload, std::string message) {
    return {Status::USER_EXCEPTION, std::move(message), std::move(payload), std::move(type)};
  }
};

// Answers one call. Move-only; reply() may be called from any thread and delivers the first reply
// only. Destroyed (or assigned over) unanswered, it answers INTERNAL "provider dropped the
// request". A default-constructed Responder answers nowhere (for a oneway request).
class Responder {
 public:
  Responder() = default;
  Responder(Responder&&) noexcept;
  Responder& operator=(Responder&&) noexcept;
  Responder(const Responder&) = delete;
  Responder& operator=(const Responder&) = delete;
  ~Responder();

  void reply(Reply reply);
  // True until the reply is delivered; false for a responder that answers nowhere.
  bool pending() const;

  // A responder that hands the reply to `deliver` (once, on the thread that answers). An
  // exception thrown by `deliver` when the responder answers on its own is logged, not thrown.
  static Responder from_callback(std::function<void(Reply)> deliver);

 private:
  struct State;
  explicit Responder(std::shared_ptr<State> state);
  static void answer_if_pending(const std::shared_ptr<State>& state) noexcept;
  std::shared_ptr<State> state_;
};

}  // namespace urs::call
