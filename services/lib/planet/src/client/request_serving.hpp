#pragma once
// Serving the requests the server routes to this client (provider role): each is handed to the
// RequestHandler with a Responder that answers on the connection the request came by.

#include <memory>

#include "client/frame_sink.hpp"
#include "urs/planet/client.hpp"

namespace urs::planet::detail {

// Runs `handler` on the calling thread (the I/O thread); one that throws is logged and its
// Responder, dropped unanswered, replies INTERNAL. A oneway request gets no reply; a reply after
// that connection closed is dropped (the caller gets PROVIDER_GONE from the server).
void serve_request(const RequestHandler& handler, const Request& request, std::weak_ptr<FrameSink> connection);

}  // namespace urs::planet::detail
