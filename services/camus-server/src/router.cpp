#include "urs/camus_server/router.hpp"

#include <spdlog/spdlog.h>

#include <iterator>
#include <vector>

#include "urs/planet/authenticator.hpp"
#include "urs/planet/reply.hpp"

namespace urs::camus_server {

Caller Caller::of(const planet::SessionPtr& session) {
  return Caller{session, session->identity().name, session->identity().role};
}

Router::Router(RouterOptions options, const Registry& registry, LocalServices& local, Scheduler& timers)
    : options_(std::move(options)), registry_(registry), local_(local), timers_(timers) {}

Router::~Router() { shutdown(); }

void Router::on_request(const planet::SessionPtr& session, planet::Request request) {
  uint64_t caller_call_id = request.call_id();
  std::weak_ptr<planet::Session> weak = session;
  route(Caller::of(session), std::move(request),
        [weak, caller_call_id](planet::CallResult result) {
          if (auto s = weak.lock()) s->send(planet::reply_frame(caller_call_id, std::move(result)));
        },
        caller_call_id);
}

void Router::call(const Caller& caller, planet::Request request, Completion done) {
  route(caller, std::move(request), std::move(done), std::nullopt);
}

void Router::route(const Caller& caller, planet::Request request, Completion done,
                   std::optional<uint64_t> caller_call_id) {
  const std::string service = request.service();
  const std::string operation = request.operation();
  const bool oneway = request.oneway();
  auto refuse = [&](planet::Status status, std::string message) {
    if (oneway) {
      spdlog::debug("oneway {}.{} from {} dropped: {}", service, operation, caller.identity, message);
      return;
    }
    done(planet::CallResult::error(status, std::move(message)));
  };

  if (request.has_caller()) {  // the server alone says who calls
    refuse(planet::PERMISSION_DENIED, "Request.caller is set by the server alone: " + service + "." + operation +
                                          " not called (a client may not name who calls)");
    return;
  }
  if (request.deadline_ms() > options_.max_deadline_ms) {
    refuse(planet::BAD_ARGUMENTS, "deadline_ms " + std::to_string(request.deadline_ms()) +
                                      " exceeds the server's limit of " + std::to_string(options_.max_deadline_ms) +
                                      " ms (max_deadline_ms)");
    return;
  }
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
  if (local) {
    const planet::Role needed = local_.required_role(service, operation);
    if (caller.role < needed) {
      refuse(planet::PERMISSION_DENIED, service + "." + operation + " needs role " + planet::role_word(needed) +
                                            "; credential '" + caller.identity + "' has role " +
                                            planet::role_word(caller.role));
      return;
    }
  }
  uint64_t deadline_ms = request.deadline_ms();
  if (deadline_ms == 0 && route) deadline_ms = route->deadline_ms;
  if (deadline_ms == 0) deadline_ms = static_cast<uint64_t>(options_.default_deadline.count());
  request.set_deadline_ms(deadline_ms);

  uint64_t call_id = 0;
  std::string refusal;
  planet::Status refusal_status = planet::OK;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    const uint64_t from = caller.session_id();
    const auto mine = caller_call_id ? by_caller_.find(from) : by_caller_.end();
    const size_t my_pending = mine == by_caller_.end() ? 0 : mine->second.size();
    if (shut_down_) {
      refusal_status = planet::UNAVAILABLE;
      refusal = "server is shutting down; " + service + "." + operation + " not called";
    } else if (caller_call_id && mine != by_caller_.end() && mine->second.count(*caller_call_id) != 0) {
      refusal_status = planet::BAD_ARGUMENTS;
      refusal = "call_id " + std::to_string(*caller_call_id) +
                " is already pending on this connection (call ids must be unique among pending calls); "
                "the first call goes on";
    } else if (!oneway && caller_call_id && my_pending >= options_.max_pending_calls_per_session) {
      refusal_status = planet::RESOURCE_EXHAUSTED;
      refusal = "this connection already has " + std::to_string(my_pending) +
                " calls pending (max_pending_calls_per_session " +
                std::to_string(options_.max_pending_calls_per_session) + ")";
    } else if (!oneway && pending_.size() >= options_.max_pending_calls) {
      refusal_status = planet::RESOURCE_EXHAUSTED;
      refusal = "the server already has " + std::to_string(pending_.size()) + " calls pending (max_pending_calls " +
                std::to_string(options_.max_pending_calls) + ")";
    } else {
      call_id = next_call_id_++;
      if (!oneway) {
        Pending entry;
        entry.caller_session = from;
        entry.from_frame = caller_call_id.has_value();
        entry.caller_call_id = caller_call_id.value_or(0);
        entry.done = std::move(done);
        entry.service = service;
        entry.operation = operation;
        entry.provider_session = local ? 0 : route->owner->id();
        entry.provider = local ? std::string(kServerPeerName) : route->owner_name;
        entry.deadline_ms = deadline_ms;
        entry.timer = timers_.schedule_after(std::chrono::milliseconds(deadline_ms),
                                             [this, call_id] { expire(call_id); });
        pending_.emplace(call_id, std::move(entry));
        if (caller_call_id) by_caller_[from][*caller_call_id] = call_id;
      }
    }
  }
  if (refusal_status != planet::OK) {
    refuse(refusal_status, std::move(refusal));
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

  // The provider learns who calls: the name and role this server authenticated.
  request.mutable_caller()->set_name(caller.identity);
  request.mutable_caller()->set_role(caller.role);
  planet::Frame frame;
  *frame.mutable_request() = std::move(request);
  if (!route->owner->send(std::move(frame))) {
    std::string message = "provider " + route->owner_name + " of " + service + " disconnected";
    if (oneway) {
      spdlog::warn("oneway {}.{} from {} dropped: {}", service, operation, caller.identity, message);
    } else {
      complete(call_id, planet::CallResult::error(planet::PROVIDER_GONE, message));
    }
  }
}

Completion Router::erase_locked(PendingMap::iterator it) {
  Pending& entry = it->second;
  timers_.cancel(entry.timer);
  if (entry.from_frame) {
    auto mine = by_caller_.find(entry.caller_session);
    if (mine != by_caller_.end()) {
      mine->second.erase(entry.caller_call_id);
      if (mine->second.empty()) by_caller_.erase(mine);
    }
  }
  Completion done = std::move(entry.done);
  pending_.erase(it);
  return done;
}

void Router::on_reply(const planet::Session& session, planet::Reply reply) {
  Completion done;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    auto it = pending_.find(reply.call_id());
    if (it == pending_.end()) {
      spdlog::debug("late or unknown reply {} from {} dropped", reply.call_id(), session.identity().name);
      return;
    }
    if (it->second.provider_session != session.id()) {
      spdlog::debug("reply {} from {} dropped: that call went to {}", reply.call_id(), session.identity().name,
                    it->second.provider);
      return;
    }
    done = erase_locked(it);
  }
  done(planet::result_of(std::move(reply)));
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
    done = erase_locked(it);
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
    done = erase_locked(it);
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
      auto next = std::next(it);
      if (entry.caller_session == session_id) {
        erase_locked(it);  // nobody is left to answer
      } else if (entry.provider_session == session_id) {
        std::string message = "provider " + entry.provider + " of " + entry.service + " disconnected";
        gone.emplace_back(erase_locked(it), std::move(message));
      }
      it = next;
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
    by_caller_.clear();
  }
  for (auto& [done, message] : failed) done(planet::CallResult::error(planet::UNAVAILABLE, message));
}

size_t Router::pending() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return pending_.size();
}

}  // namespace urs::camus_server
