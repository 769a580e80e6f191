#include <spdlog/spdlog.h>

#include <atomic>
#include <exception>
#include <utility>

#include "client/request_serving.hpp"
#include "urs/planet/client.hpp"
#include "urs/planet/reply.hpp"

namespace urs::planet {

struct Responder::State {
  std::function<void(CallResult)> deliver;  // empty for a oneway request: nothing is sent
  std::atomic<bool> answered{false};
};

namespace {

void answer_if_pending(const std::shared_ptr<Responder::State>& state) noexcept {
  if (!state || !state->deliver || state->answered.exchange(true)) return;
  try {
    state->deliver(CallResult::error(Status::INTERNAL, "provider dropped the request"));
  } catch (const std::exception& exception) {
    spdlog::error("planet: answering a dropped request failed: {}", exception.what());
  }
}

}  // namespace

Responder::Responder(std::shared_ptr<State> state) : state_(std::move(state)) {}
Responder::Responder(Responder&&) noexcept = default;
Responder& Responder::operator=(Responder&& other) noexcept {
  if (this != &other) {
    answer_if_pending(state_);
    state_ = std::move(other.state_);
  }
  return *this;
}
Responder::~Responder() { answer_if_pending(state_); }

void Responder::reply(CallResult result) {
  if (!state_ || state_->answered.exchange(true)) return;
  if (state_->deliver) state_->deliver(std::move(result));
}

bool Responder::pending() const {
  return state_ && state_->deliver && !state_->answered.load();
}

Responder Responder::from_callback(std::function<void(CallResult)> fn) {
  auto state = std::make_shared<State>();
  state->deliver = std::move(fn);
  return Responder(std::move(state));
}

namespace detail {

void serve_request(const RequestHandler& handler, const Request& request, std::weak_ptr<FrameSink> connection) {
  auto state = std::make_shared<Responder::State>();
  if (!request.oneway()) {
    state->deliver = [connection = std::move(connection), call_id = request.call_id()](CallResult result) {
      auto strong = connection.lock();
      if (!strong) return;  // that connection is gone; the caller gets PROVIDER_GONE
      strong->send(reply_frame(call_id, std::move(result)));
    };
  }
  try {
    handler(request, Responder(std::move(state)));
  } catch (const std::exception& exception) {
    spdlog::error("planet: request handler for {}.{} threw: {}", request.service(), request.operation(),
                  exception.what());
  }
}

}  // namespace detail

}  // namespace urs::planet
