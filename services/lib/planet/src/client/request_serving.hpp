#pragma once
// Serving the requests the server routes to this client (provider role): each is handed to the
// RequestHandler with a Responder that answers on the connection the request came by.

#include <memory>

#include "client/frame_sink.hpp"
#include "urs/call/recorder.hpp"
#include "urs/planet/client.hpp"

namespace urs::planet::detail {

// Runs `handler` on the calling thread (the I/O thread) inside a TraceScope of the request's
// traceparent; one that throws is logged and its Responder, dropped unanswered, replies INTERNAL.
// A oneway request gets no reply; a reply after that connection closed is dropped (the caller gets
// PROVIDER_GONE from the server). With `served`, the call is counted there when answered, under
// its names if `registered` (a service of this client's: the server checked the operation against
// the interface it registered), else as "other". Its end is logged at debug level.
void serve_request(const RequestHandler& handler, const Request& request, std::weak_ptr<FrameSink> connection,
                   call::CallRecorder* served = nullptr, bool registered = false);

}  // namespace urs::planet::detail
