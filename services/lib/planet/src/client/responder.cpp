#include <spdlog/spdlog.h>

#include <chrono>
#include <exception>
#include <optional>
#include <utility>

#include "client/request_serving.hpp"
#include "urs/planet/call_adapter.hpp"
#include "urs/planet/client.hpp"
#include "urs/planet/reply.hpp"

namespace urs::planet {

void Responder::reply(CallResult result) { neutral_.reply(to_reply(std::move(result))); }

Responder Responder::from_callback(std::function<void(CallResult)> fn) {
  return Responder(to_call_responder(std::move(fn)));
}

namespace detail {

void serve_request(const RequestHandler& handler, const Request& request, std::weak_ptr<FrameSink> connection,
                   call::CallRecorder* served, bool registered) {
  const auto trace = util::TraceContext::parse(request.traceparent());
  util::TraceScope scope(trace);
  Responder responder;  // a oneway request's answers nothing
  if (!request.oneway()) {
    struct Recording {
      call::CallRecorder* recorder = nullptr;
      std::string service;
      std::string operation;
      std::optional<util::TraceContext> trace;
      std::chrono::steady_clock::time_point start;
      bool logged = false;
    };
    Recording recording;
    const bool logged = spdlog::should_log(spdlog::level::debug);
    if (served != nullptr || logged) {
      recording = {served,
                   registered || served == nullptr ? request.service() : std::string(),
                   registered || served == nullptr ? request.operation() : std::string(),
                   trace,
                   std::chrono::steady_clock::now(),
                   logged};
    }
    responder =
        Responder(call::Responder::from_callback([connection = std::move(connection), call_id = request.call_id(),
                                                  recording = std::move(recording)](call::Reply reply) {
          if (recording.recorder != nullptr || recording.logged) {
            const auto elapsed = std::chrono::steady_clock::now() - recording.start;
            if (recording.recorder != nullptr) {
              recording.recorder->record(recording.service, recording.operation, reply.status, elapsed);
            }
            if (recording.logged) {
              util::TraceScope scope(recording.trace);
              spdlog::debug("served {}.{}: {} in {} us", recording.service.empty() ? "other" : recording.service,
                            recording.operation.empty() ? "other" : recording.operation,
                            call::status_name(reply.status),
                            std::chrono::duration_cast<std::chrono::microseconds>(elapsed).count());
            }
          }
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
