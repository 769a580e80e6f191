#pragma once
// The Planet protocol's edge of the neutral call model (urs/call/call.hpp): a Planet request and
// its Responder become a call::Request and a call::Responder, a call::Reply becomes the Planet
// reply, and back. Nothing outside the Planet library and the CAMUS session code needs Planet's
// types to serve or make a call.
//
// planet::CallResult stays the Planet library's own type (not an alias of call::Reply): it carries
// the wire enum planet::Status, which the client, the server and the CAMUS router read and write on
// every frame; the conversion happens once, here, where a call leaves or enters Planet.

#include <chrono>

#include "planet.pb.h"
#include "urs/call/call.hpp"
#include "urs/planet/authenticator.hpp"
#include "urs/planet/client.hpp"
#include "urs/planet/status.hpp"

namespace urs::planet {

// Both enums carry the same numbers (checked at compile time in call_adapter.cpp); a Planet
// number no call::Status has (a newer peer's) becomes INTERNAL.
call::Status to_call(Status status);
Status to_planet(call::Status status);

call::Reply to_reply(CallResult result);
CallResult to_call_result(call::Reply reply);

// The caller as the Planet server verified it (the session's credential); `space` is the server's.
call::Identity caller_identity(const std::string& space, const Identity& identity);
call::Identity caller_identity(const std::string& space, const std::string& name, Role role);

// The caller a Request routed by the server of space `space` names (Request.caller, which only
// the server sets): {space, name, role}; empty if it names none. Only for a Request that came on
// a Planet client's session with its server (Client's request handler), never one a peer sent.
call::Identity routed_caller(const Request& request, const std::string& space);

// The neutral request for a Planet request received at `received`: deadline_ms 0 gives no
// deadline. A provider behind a Planet client learns its caller from routed_caller().
call::Request to_call_request(const Request& request, call::Identity caller,
                              std::chrono::steady_clock::time_point received = std::chrono::steady_clock::now());

// A responder that answers through the Planet responder (converting the reply).
call::Responder to_call_responder(Responder responder);
// A call::Responder that answers `done` with the Planet result.
call::Responder to_call_responder(std::function<void(CallResult)> done);
// The handler of a Planet call (Client::call_async) that answers `responder` with its result.
ReplyHandler answering(call::Responder responder);
// What is left of `request`'s deadline as a Planet call's deadline: 0 for none, at least 1 ms.
std::chrono::milliseconds deadline_left(const call::Request& request,
                                        std::chrono::steady_clock::time_point now = std::chrono::steady_clock::now());

}  // namespace urs::planet
