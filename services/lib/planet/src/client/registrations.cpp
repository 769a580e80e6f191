#include "client/registrations.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <utility>

namespace urs::planet::detail {

Registrations::Registrations(PendingCalls& calls) : calls_(calls) {}

void Registrations::send_locked(const camus::RegisterRequest& registration, ReplyHandler handler, bool first,
                                Deferred& out) {
  Request request;
  request.set_service("camus.registry");
  request.set_operation("Register");
  request.set_payload(registration.SerializeAsString());
  if (!handler) {
    handler = [name = registration.service().name()](CallResult result) {
      if (!result.ok()) {
        spdlog::error("planet: registering service '{}' failed: {}: {}", name, status_name(result.status),
                      result.message);
      }
    };
  }
  calls_.start(std::move(request), std::chrono::milliseconds(0), std::move(handler), out, first);
}

void Registrations::add(const camus::RegisterRequest& registration, ReplyHandler handler, Deferred& out) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (closed_) {
    defer_reply(out, std::move(handler), CallResult::error(Status::UNAVAILABLE, closed_message_));
    return;
  }
  const std::string& name = registration.service().name();
  auto it = std::find_if(registrations_.begin(), registrations_.end(),
                         [&](const Registration& r) { return r.request.service().name() == name; });
  if (it == registrations_.end()) {
    registrations_.push_back({registration, nullptr});
    it = registrations_.end() - 1;
  } else {
    it->request = registration;
  }
  if (open_) {
    send_locked(registration, std::move(handler), /*first=*/false, out);
  } else {
    // Sent first thing on the next session; the handler gets that attempt's result.
    it->first_handler = std::move(handler);
  }
}

void Registrations::remove(const std::string& name) {
  std::lock_guard<std::mutex> lock(mutex_);
  registrations_.erase(std::remove_if(registrations_.begin(), registrations_.end(),
                                      [&](const Registration& r) { return r.request.service().name() == name; }),
                       registrations_.end());
}

bool Registrations::has(const std::string& name) const {
  std::lock_guard<std::mutex> lock(mutex_);
  return std::any_of(registrations_.begin(), registrations_.end(),
                     [&](const Registration& r) { return r.request.service().name() == name; });
}

void Registrations::open(Deferred& out) {
  std::lock_guard<std::mutex> lock(mutex_);
  open_ = true;
  for (Registration& registration : registrations_) {
    send_locked(registration.request, std::move(registration.first_handler), /*first=*/true, out);
    registration.first_handler = nullptr;
  }
}

void Registrations::detach() {
  std::lock_guard<std::mutex> lock(mutex_);
  open_ = false;
}

void Registrations::close(const std::string& message, Deferred& out) {
  std::lock_guard<std::mutex> lock(mutex_);
  closed_ = true;
  closed_message_ = message;
  open_ = false;
  for (Registration& registration : registrations_) {
    defer_reply(out, std::move(registration.first_handler), CallResult::error(Status::UNAVAILABLE, message));
    registration.first_handler = nullptr;
  }
}

}  // namespace urs::planet::detail
