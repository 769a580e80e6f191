#include "urs/camus_server/router.hpp"

#include <spdlog/spdlog.h>

#include <vector>

namespace urs::camus_server {

namespace {

// Payloads are moved, never copied: a reply may carry a 921,600-byte image.
planet::Frame reply_frame(uint64_t call_id, planet::CallResult&& result) {
  planet::Frame frame;
  auto* reply = frame.mutable_reply();
  reply->set_call_id(call_id);
  reply->set_status(result.status);
  reply->set_message(std::move(result.message));
  reply->set_payload(std::move(result.payload));
  reply->set_exception_type(std::move(result.exception_type));
  return frame;
}

}  // namespace

Router::Router(RouterOptions options, const Registry& registry, LocalServices& local, Scheduler& timers)
    : options_(std::move(options)), registry_(registry), local_(local), timers_(timers) {}

Router::~Router() { shutdown(); }

void Router::on_request(const planet::SessionPtr& session, planet::Request request) {
  Caller caller{session, session->hello().peer_name()};
  uint64_t caller_call_id = request.call_id();
  std::weak_ptr<planet::Session> weak = session;
  call(caller, std::move(request), [weak, caller_call_id](planet::CallResult result) {
    if (auto s = weak.lock()) s->send(reply_frame(caller_call_id, std::move(result)));
  });
}

void Router::call(const Caller& caller, planet::Request request, Completion done) {
  const std::string service = request.service();
  const std::string operation = request.operation();
  const bool oneway = request.oneway();
  auto refuse = [&](planet::Status status, std::string message) {
    if (oneway) {
      spdlog::warn("oneway {}.{} from {} dropped: {}", service, operation, caller.peer, message);
      return;
    }
    done(planet::CallResult::error(status, std::move(message)));
  };

  auto route = registry_.route(service);
  bool local = local_.serves(service);
  if (!route && !local) {
    refuse(planet::UNKNOWN_SERVICE, "no service named '" + service + "' in space " + options_.space);
    return;
  }
  if (route && route->schema && route->schema->service().FindMethodByName(operation) == nullptr) {
    refuse(planet::UNKNOWN_OPERATION,
           "interface " + route->interface + " has no operation '" + operation + "'");
    return;
  }
  if (!local && route->builtin) {
    refuse(planet::INTERNAL, "built-in service " + service + " has no implementation in this server");
    return;
  }
  uint32_t deadline_ms = request.deadline_ms();
  if (deadline_ms == 0 && route) deadline_ms = route->deadline_ms;
  if (deadline_ms == 0) deadline_ms = static_cast<uint32_t>(options_.default_deadline.count());
  request.set_deadline_ms(deadline_ms);

  uint64_t call_id = 0;
  bool shut_down = false;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    shut_down = shut_down_;
    if (!shut_down) {
      call_id = next_call_id_++;
      if (!oneway) {
        Pending entry;
        entry.caller_session = caller.session_id();
        entry.done = std::move(done);
        entry.service = service;
        entry.operation = operation;
        entry.provider_session = local ? 0 : route->owner->id();
        entry.provider = local ? std::string(kServerPeerName) : route->owner_name;
        entry.deadline_ms = deadline_ms;
        entry.timer = timers_.schedule_after(std::chrono::milliseconds(deadline_ms),
                                             [this, call_id] { expire(call_id); });
        pending_.emplace(call_id, std::move(entry));
      }
    }
  }
  if (shut_down) {
    refuse(planet::UNAVAILABLE, "server is shutting down; " + service + "." + operation + " not called");
    return;
  }
  request.set_call_id(call_id);

  if (local) {
    if (oneway) {
      local_.dispatch(caller, request, [](planet::CallResult) {});
    } else {
      local_.dispatch(caller, request, [this, call_id](planet::CallResult result) { complete(call_id, std::move(result)); });
    }
    return;
  }

  planet::Frame frame;
  *frame.mutable_request() = std::move(request);
  if (!route->owner->send(std::move(frame))) {
    std::string message = "provider " + route->owner_name + " of " + service + " disconnected";
    if (oneway) {
      spdlog::warn("oneway {}.{} from {} dropped: {}", service, operation, caller.peer, message);
    } else {
      complete(call_id, planet::CallResult::error(planet::PROVIDER_GONE, message));
    }
  }
}

void Router::on_reply(const planet::Session& session, planet::Reply reply) {
  Completion done;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    auto it = pending_.find(reply.call_id());
    if (it == pending_.end()) {
      spdlog::debug("late or unknown reply {} from {} dropped", reply.call_id(), session.hello().peer_name());
      return;
    }
    if (it->second.provider_session != session.id()) {
      spdlog::warn("reply {} from {} dropped: that call went to {}", reply.call_id(), session.hello().peer_name(),
                   it->second.provider);
      return;
    }
    timers_.cancel(it->second.timer);
    done = std::move(it->second.done);
    pending_.erase(it);
  }
  planet::CallResult result;
  result.status = reply.status();
  result.message = std::move(*reply.mutable_message());
  result.payload = std::move(*reply.mutable_payload());
  result.exception_type = std::move(*reply.mutable_exception_type());
  done(std::move(result));
}

void Router::complete(uint64_t call_id, planet::CallResult result) {
  Completion done;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    auto it = pending_.find(call_id);
    if (it == pending_.end()) {
      spdlog::debug("late local reply {} dropped", call_id);
      return;
    }
    timers_.cancel(it->second.timer);
    done = std::move(it->second.done);
    pending_.erase(it);
  }
  done(std::move(result));
}

void Router::expire(uint64_t call_id) {
  Completion done;
  std::string message;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    auto it = pending_.find(call_id);
    if (it == pending_.end()) return;
    const Pending& entry = it->second;
    message = "no reply from " + entry.service + "." + entry.operation + " within " +
              std::to_string(entry.deadline_ms) + " ms";
    done = std::move(it->second.done);
    pending_.erase(it);
  }
  spdlog::debug("{}", message);
  done(planet::CallResult::error(planet::DEADLINE_EXCEEDED, message));
}

void Router::on_session_closed(uint64_t session_id) {
  std::vector<std::pair<Completion, std::string>> gone;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    for (auto it = pending_.begin(); it != pending_.end();) {
      Pending& entry = it->second;
      if (entry.caller_session == session_id) {
        timers_.cancel(entry.timer);  // nobody is left to answer
        it = pending_.erase(it);
      } else if (entry.provider_session == session_id) {
        timers_.cancel(entry.timer);
        gone.emplace_back(std::move(entry.done),
                          "provider " + entry.provider + " of " + entry.service + " disconnected");
        it = pending_.erase(it);
      } else {
        ++it;
      }
    }
  }
  for (auto& [done, message] : gone) done(planet::CallResult::error(planet::PROVIDER_GONE, message));
}

void Router::shutdown() {
  std::vector<std::pair<Completion, std::string>> failed;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    shut_down_ = true;
    for (auto& [id, entry] : pending_) {
      timers_.cancel(entry.timer);
      failed.emplace_back(std::move(entry.done),
                          "server is shutting down; no reply from " + entry.service + "." + entry.operation);
    }
    pending_.clear();
  }
  for (auto& [done, message] : failed) done(planet::CallResult::error(planet::UNAVAILABLE, message));
}

size_t Router::pending() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return pending_.size();
}

}  // namespace urs::camus_server
