#include "urs/call/call.hpp"

#include <spdlog/spdlog.h>

#include <atomic>
#include <exception>

namespace urs::call {

std::string_view status_name(Status status) {
  switch (status) {
    case Status::OK:
      return "OK";
    case Status::UNKNOWN_SERVICE:
      return "UNKNOWN_SERVICE";
    case Status::UNKNOWN_OPERATION:
      return "UNKNOWN_OPERATION";
    case Status::BAD_ARGUMENTS:
      return "BAD_ARGUMENTS";
    case Status::PROVIDER_GONE:
      return "PROVIDER_GONE";
    case Status::DEADLINE_EXCEEDED:
      return "DEADLINE_EXCEEDED";
    case Status::INTERNAL:
      return "INTERNAL";
    case Status::USER_EXCEPTION:
      return "USER_EXCEPTION";
    case Status::UNAVAILABLE:
      return "UNAVAILABLE";
    case Status::UNAUTHENTICATED:
      return "UNAUTHENTICATED";
    case Status::PAYLOAD_TOO_LARGE:
      return "PAYLOAD_TOO_LARGE";
    case Status::ALREADY_EXISTS:
      return "ALREADY_EXISTS";
    case Status::NOT_FOUND:
      return "NOT_FOUND";
    case Status::RESOURCE_EXHAUSTED:
      return "RESOURCE_EXHAUSTED";
    case Status::PERMISSION_DENIED:
      return "PERMISSION_DENIED";
  }
  return "UNKNOWN_STATUS";  // a value cast from a number outside the set
}

std::optional<Status> status_from_number(std::int64_t number) {
  if (number < 0 || number > kLastStatus) return std::nullopt;
  return static_cast<Status>(number);
}

struct Responder::State {
  std::function<void(Reply)> deliver;
  std::atomic<bool> answered{false};
};

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

void Responder::reply(Reply reply) {
  if (!state_ || state_->answered.exchange(true)) return;
  state_->deliver(std::move(reply));
}

bool Responder::pending() const { return state_ && !state_->answered.load(); }

Responder Responder::from_callback(std::function<void(Reply)> deliver) {
  if (!deliver) return Responder();
  auto state = std::make_shared<State>();
  state->deliver = std::move(deliver);
  return Responder(std::move(state));
}

void Responder::answer_if_pending(const std::shared_ptr<State>& state) noexcept {
  if (!state || state->answered.exchange(true)) return;
  try {
    state->deliver(Reply::error(Status::INTERNAL, "provider dropped the request"));
  } catch (const std::exception& exception) {
    spdlog::error("call: answering a dropped request failed: {}", exception.what());
  } catch (...) {
    spdlog::error("call: answering a dropped request failed with an exception that is not a std::exception");
  }
}

}  // namespace urs::call
