#include "urs/camus_server/router.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <iterator>
#include <tuple>
#include <vector>

#include "urs/camus_server/topic_pattern.hpp"
#include "urs/planet/authenticator.hpp"
#include "urs/planet/reply.hpp"

namespace urs::camus_server {

Caller Caller::of(const planet::SessionPtr& session) {
  return Caller{session, session->identity().name, session->identity().role};
}

Router::Router(RouterOptions options, const Registry& registry, LocalServices& local, Scheduler& timers)
    : options_(std::move(options)),
      registry_(registry),
      local_(local),
      timers_(timers),
      shares_(planet::FairShare::Limits{options_.max_pending_calls, options_.max_pending_calls_per_credential,
                                        uint64_t{options_.max_pending_calls} * options_.reserved_percent / 100,
                                        "max_pending_calls", "max_pending_calls_per_credential",
                                        "reserved_percent " + std::to_string(options_.reserved_percent),
                                        "calls pending"}) {}

Router::~Router() { shutdown(); }

namespace {

// Sets `request.traceparent` to what this hop sends on: the caller's trace under a new parent id,
// or a new trace. Returns it.
util::TraceContext carry_trace(planet::Request& request) {
  const auto incoming = util::TraceContext::parse(request.traceparent());
  util::TraceContext trace = incoming ? incoming->child() : util::TraceContext::start();
  request.set_traceparent(trace.traceparent());
  return trace;
}

}  // namespace

void Router::on_request(const planet::SessionPtr& session, planet::Request request) {
  uint64_t caller_call_id = request.call_id();
  std::weak_ptr<planet::Session> weak = session;
  Completion reply = [weak, caller_call_id](planet::CallResult result) {
    if (auto s = weak.lock()) s->send(planet::reply_frame(caller_call_id, std::move(result)));
  };
  const Caller caller = Caller::of(session);
  const util::TraceContext trace = carry_trace(request);
  if ((options_.calls != nullptr || spdlog::should_log(spdlog::level::debug)) && !request.oneway()) {
    reply = recorded(request, caller, trace, std::move(reply));
  }
  route(caller, std::move(request), std::move(reply), caller_call_id);
}

Completion Router::recorded(const planet::Request& request, const Caller& caller, const util::TraceContext& trace,
                            Completion done) const {
  // The labels are the registry's names: a service it holds with an interface, and an operation
  // of that interface; anything else is counted as "other".
  std::string service;
  std::string operation;
  if (auto schema = registry_.schema_for_service(request.service())) {
    service = request.service();
    if (schema->service().FindMethodByName(request.operation()) != nullptr) operation = request.operation();
  }
  std::string logged;  // what the call's debug line names, when there is one
  if (spdlog::should_log(spdlog::level::debug)) {
    logged = request.service() + "." + request.operation() + " from " + caller.identity;
  }
  return [this, done = std::move(done), service = std::move(service), operation = std::move(operation),
          logged = std::move(logged), trace, start = std::chrono::steady_clock::now()](planet::CallResult result) {
    const auto elapsed = std::chrono::steady_clock::now() - start;
    if (options_.calls != nullptr) {
      options_.calls->record(service, operation, static_cast<call::Status>(result.status), elapsed);
    }
    if (!logged.empty()) {
      util::TraceScope scope(trace);
      spdlog::debug("call {}: {} in {} us", logged, planet::status_name(result.status),
                    std::chrono::duration_cast<std::chrono::microseconds>(elapsed).count());
    }
    done(std::move(result));
  };
}

void Router::call(const Caller& caller, planet::Request request, Completion done) {
  carry_trace(request);
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
    refusals_.count("max_deadline_ms");
    refuse(planet::BAD_ARGUMENTS, "deadline_ms " + std::to_string(request.deadline_ms()) +
                                      " exceeds the server's limit of " + std::to_string(options_.max_deadline_ms) +
                                      " ms (max_deadline_ms)");
    return;
  }
  auto route = registry_.route(service);
  bool local = local_.serves(service);
  if (!route && !local) {
    refuse(planet::UNKNOWN_SERVICE, "no service named " + quote_prefix(service) + " in space " + options_.space);
    return;
  }
  if (route && route->schema && route->schema->service().FindMethodByName(operation) == nullptr) {
    refuse(planet::UNKNOWN_OPERATION, "interface " + route->interface + " has no operation " + quote_prefix(operation));
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
  const RouteProvider* provider = nullptr;
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
      refusals_.count("max_pending_calls_per_session");
      refusal_status = planet::RESOURCE_EXHAUSTED;
      refusal = "this connection already has " + std::to_string(my_pending) +
                " calls pending (max_pending_calls_per_session " +
                std::to_string(options_.max_pending_calls_per_session) + ")";
    } else if (!oneway && !(refusal = shares_.take(caller.holder(), 1)).empty()) {
      refusal_status = planet::RESOURCE_EXHAUSTED;
    } else if (!local && (provider = pick_locked(*route, {})) == nullptr) {
      refusal_status = planet::PROVIDER_GONE;
      refusal = "no provider of " + service + " is connected";
    } else {
      call_id = next_call_id_++;
      if (!oneway) {
        Pending entry;
        entry.caller_session = from;
        entry.caller = caller.holder();
        entry.from_frame = caller_call_id.has_value();
        entry.caller_call_id = caller_call_id.value_or(0);
        entry.done = std::move(done);
        entry.service = service;
        entry.operation = operation;
        entry.provider_session = local ? 0 : provider->session->id();
        entry.provider = local ? std::string(kServerPeerName) : provider->name;
        if (!local) {
          ProviderLoad& load = providers_[entry.provider_session];
          ++load.pending;
          entry.sent_tick = load.reply_tick;
        }
        entry.deadline_ms = deadline_ms;
        entry.timer =
            timers_.schedule_after(std::chrono::milliseconds(deadline_ms), [this, call_id] { expire(call_id); });
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
      local_.dispatch(caller, request,
                      [this, call_id](planet::CallResult result) { complete(call_id, std::move(result)); });
    }
    return;
  }

  // The provider learns who calls: the name and role this server authenticated.
  request.mutable_caller()->set_name(caller.identity);
  request.mutable_caller()->set_role(caller.role);
  std::vector<uint64_t> tried;
  for (;;) {
    // A frame a closed connection refuses was never received: the next provider may take it.
    // Only then is the request needed again, so it is copied only while another provider is left.
    const bool last = tried.size() + 1 >= route->providers.size();
    planet::Frame frame;
    *frame.mutable_request() = last ? std::move(request) : request;
    if (provider->session->send(std::move(frame))) return;
    std::string message = "provider " + provider->name + " of " + service + " disconnected";
    tried.push_back(provider->session->id());
    {
      std::lock_guard<std::mutex> lock(mutex_);
      release_locked(tried.back(), !oneway, /*closed=*/true);
      auto it = pending_.find(call_id);
      if (!oneway && it == pending_.end()) return;  // answered meanwhile (the connection's close failed it)
      provider = last ? nullptr : pick_locked(*route, tried);
      if (provider != nullptr && !oneway) {
        it->second.provider_session = provider->session->id();
        it->second.provider = provider->name;
        ProviderLoad& load = providers_[it->second.provider_session];
        ++load.pending;
        it->second.sent_tick = load.reply_tick;
      }
    }
    if (provider == nullptr) {
      if (oneway) {
        spdlog::warn("oneway {}.{} from {} dropped: {}", service, operation, caller.identity, message);
      } else {
        complete(call_id, planet::CallResult::error(planet::PROVIDER_GONE, message));
      }
      return;
    }
    spdlog::debug("{}.{}: {}; trying {}", service, operation, message, provider->name);
  }
}

const RouteProvider* Router::pick_locked(const Route& route, const std::vector<uint64_t>& tried) {
  const RouteProvider* best = nullptr;
  ProviderLoad best_load;
  for (const RouteProvider& candidate : route.providers) {
    if (!candidate.session) continue;
    const uint64_t id = candidate.session->id();
    if (std::find(tried.begin(), tried.end(), id) != tried.end()) continue;
    auto known = providers_.find(id);
    const ProviderLoad load = known == providers_.end() ? ProviderLoad{} : known->second;
    const bool better = best == nullptr || std::tie(load.suspected, load.pending, load.last_pick) <
                                               std::tie(best_load.suspected, best_load.pending, best_load.last_pick);
    if (better) {
      best = &candidate;
      best_load = load;
    }
  }
  if (best != nullptr) providers_[best->session->id()].last_pick = ++pick_tick_;
  return best;
}

void Router::release_locked(uint64_t provider_session, bool pending, bool closed) {
  auto load = providers_.find(provider_session);
  if (load == providers_.end()) return;
  if (pending && load->second.pending > 0) --load->second.pending;
  if (closed && load->second.pending == 0) providers_.erase(load);
}

Completion Router::erase_locked(PendingMap::iterator it) {
  Pending& entry = it->second;
  timers_.cancel(entry.timer);
  shares_.give(entry.caller, 1);
  if (entry.provider_session != 0) release_locked(entry.provider_session, true, false);
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
    // Any reply, late ones included, shows the provider is not stuck.
    if (auto load = providers_.find(session.id()); load != providers_.end()) {
      ++load->second.reply_tick;
      if (load->second.suspected) {
        load->second.suspected = false;
        spdlog::info("provider {} (connection {}) answers again", session.identity().name, session.id());
      }
    }
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
    auto load = providers_.find(entry.provider_session);
    if (load != providers_.end() && !load->second.suspected && load->second.reply_tick == entry.sent_tick) {
      load->second.suspected = true;
      spdlog::info(
          "provider {} (connection {}) suspected: nothing from it since {}.{} was forwarded {} ms ago; "
          "calls go to the other providers while it is silent",
          entry.provider, entry.provider_session, entry.service, entry.operation, entry.deadline_ms);
    }
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
    providers_.erase(session_id);
  }
  for (auto& [done, message] : gone) done(planet::CallResult::error(planet::PROVIDER_GONE, message));
}

size_t Router::pending_at(uint64_t session_id) const {
  std::lock_guard<std::mutex> lock(mutex_);
  auto load = providers_.find(session_id);
  return load == providers_.end() ? 0 : load->second.pending;
}

bool Router::suspected(uint64_t session_id) const {
  std::lock_guard<std::mutex> lock(mutex_);
  auto load = providers_.find(session_id);
  return load != providers_.end() && load->second.suspected;
}

void Router::shutdown() {
  std::vector<std::pair<Completion, std::string>> failed;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    shut_down_ = true;
    for (auto& [id, entry] : pending_) {
      timers_.cancel(entry.timer);
      shares_.give(entry.caller, 1);
      failed.emplace_back(std::move(entry.done),
                          "server is shutting down; no reply from " + entry.service + "." + entry.operation);
    }
    pending_.clear();
    by_caller_.clear();
  }
  for (auto& [done, message] : failed) done(planet::CallResult::error(planet::UNAVAILABLE, message));
}

std::vector<std::pair<std::string, uint64_t>> Router::refusals() const {
  planet::Refusals all;
  for (const auto& [limit, count] : refusals_.snapshot()) all.count(limit, count);
  for (const auto& [limit, count] : shares_.refusals()) all.count(limit, count);
  return all.snapshot();
}

size_t Router::pending() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return pending_.size();
}

}  // namespace urs::camus_server
