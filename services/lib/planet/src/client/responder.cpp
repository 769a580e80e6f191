#include <spdlog/spdlog.h>

#include <exception>
#include <utility>

#include "client/request_serving.hpp"
#include "urs/planet/call_adapter.hpp"
#include "urs/planet/client.hpp"
#include "urs/planet/reply.hpp"

namespace urs::planet {

void Responder::reply(CallResult result) { neutral_.reply(to_reply(std::move(result))); }

Responder Responder::from_callback(std::function<void(CallResult)> fn) { return Responder(to_call_responder(std::move(fn))); }

namespace detail {

void serve_request(const RequestHandler& handler, const Request& request, std::weak_ptr<FrameSink> connection) {
  Responder responder;  // a oneway request's answers nothing
  if (!request.oneway()) {
    responder = Responder(call::Responder::from_callback(
        [connection = std::move(connection), call_id = request.call_id()](call::Reply reply) {
          auto strong = connection.lock();
          if (!strong) return;  // that connection is gone; the caller gets PROVIDER_GONE
          strong->send(reply_frame(call_id, to_call_result(std::move(reply))));
        }));
  }
  try {
    handler(request, std::move(responder));
  } catch (const std::exception& exception) {
    spdlog::error("planet: request handler for {}.{} threw: {}", request.service(), request.operation(),
                  exception.what());
  }
}

}  // namespace detail

}  // namespace urs::planet
