#include "urs/bridge/core/route_reconciler.hpp"

#include <spdlog/spdlog.h>

namespace urs::bridge::core {

namespace {

std::string reasons(const OfferOutcome& outcome) {
  std::string text;
  for (const auto& refusal : outcome.refused) text += (text.empty() ? "" : "; ") + refusal.reason;
  return text;
}

}  // namespace

RouteReconciler::RouteReconciler(std::string direction, std::vector<RouteRule> rules, ServiceSource& source,
                                 ServiceOffering& target, std::chrono::milliseconds retry_period, NameFilter names)
    : direction_(std::move(direction)),
      rules_(std::move(rules)),
      names_(std::move(names)),
      source_(source),
      target_(target),
      retry_period_(retry_period) {}

RouteReconciler::Changes RouteReconciler::reconcile(const std::vector<Offer>& offers, Clock::time_point now) {
  Changes changes;
  struct Wanted {
    const Offer* offer;
    std::string name;
    uint32_t deadline_ms;
  };
  std::map<std::string, Wanted> wanted;  // by key: ordered, so the least key wins a disputed name
  for (const auto& offer : offers) {
    if (!bridgeable(offer)) continue;
    const RouteRule* rule = first_match(rules_, offer);
    if (rule == nullptr) continue;
    std::string name = target_.usable_name(stand_in_name(*rule, offer));
    if (!names_.admits(name)) continue;
    wanted.emplace(offer.key, Wanted{&offer, std::move(name), rule->deadline_ms});
  }

  if (restarted_) {  // what the target may have lost and is still wanted as it was is offered again
    std::lock_guard lock(mutex_);
    for (auto it = routes_.begin(); it != routes_.end();) {
      const auto want = wanted.find(it->first);
      const bool unchanged = want != wanted.end() && want->second.offer->revision == it->second.offer.revision &&
                             want->second.name == it->second.name;
      it = unchanged ? routes_.erase(it) : std::next(it);
    }
    pending_.clear();
    restarted_ = false;
  }

  // Routes whose offer vanished, or that must be made again.
  for (auto it = routes_.begin(); it != routes_.end();) {
    const auto want = wanted.find(it->first);
    const char* why = nullptr;
    if (want == wanted.end()) {
      why = "its offer is gone";
    } else if (want->second.offer->revision != it->second.offer.revision) {
      why = "its offer changed";
    } else if (want->second.name != it->second.name) {
      why = "its name changed";
    }
    if (why == nullptr) {
      ++it;
      continue;
    }
    spdlog::info("bridge {}: withdrawing {} ({})", direction_, it->second.name, why);
    target_.withdraw(it->second);
    changes.withdrawn.push_back(it->second.name);
    std::lock_guard lock(mutex_);
    it = routes_.erase(it);
  }
  for (auto it = pending_.begin(); it != pending_.end();) {
    it = wanted.count(it->first) ? std::next(it) : pending_.erase(it);
  }

  std::map<std::string, std::string> holders;  // stand-in name -> offer key
  for (const auto& [key, route] : routes_) holders[route.name] = key;

  for (const auto& wanted_entry : wanted) {
    const std::string& key = wanted_entry.first;  // not a structured binding: the lambda below uses them
    const Wanted& want = wanted_entry.second;
    const auto routed = routes_.find(key);
    if (routed != routes_.end()) {
      if (routed->second.offer.properties != want.offer->properties || routed->second.deadline_ms != want.deadline_ms) {
        {
          std::lock_guard lock(mutex_);
          routed->second.offer = *want.offer;
          routed->second.deadline_ms = want.deadline_ms;
        }
        target_.update(routed->second);
        changes.updated.push_back(want.name);
      }
      continue;
    }
    Pending& pending = pending_[key];
    auto refuse = [&](const std::string& reason) {
      if (reason != pending.reason) {
        spdlog::warn("bridge {}: {} not offered as {}: {}", direction_, want.offer->name, want.name, reason);
      }
      pending.reason = reason;
      pending.retry_at = now + retry_period_;
      changes.refused[key] = reason;
    };
    const auto holder = holders.find(want.name);
    if (holder != holders.end()) {
      refuse("the name is taken by " + routes_.at(holder->second).offer.name);
      pending.retry_at = now;  // free to take as soon as the holder is gone
      continue;
    }
    if (now < pending.retry_at) {
      changes.refused[key] = pending.reason;
      continue;
    }
    Route route{*want.offer, want.name, want.deadline_ms};
    OfferOutcome outcome;
    try {
      outcome = target_.offer(route, source_);
    } catch (const std::exception& e) {
      outcome = OfferOutcome::refuse(e.what());
    }
    if (!outcome.ok()) {
      refuse(reasons(outcome));
      continue;
    }
    if (!pending.reason.empty())
      spdlog::info("bridge {}: {} offered as {} at last", direction_, want.offer->name, want.name);
    pending_.erase(key);
    holders[want.name] = key;
    changes.offered.push_back(want.name);
    std::lock_guard lock(mutex_);
    routes_.emplace(key, std::move(route));
  }
  return changes;
}

void RouteReconciler::target_restarted() { restarted_ = true; }

void RouteReconciler::withdraw_all() {
  std::map<std::string, Route> routes;
  {
    std::lock_guard lock(mutex_);
    routes.swap(routes_);
  }
  for (const auto& [key, route] : routes) target_.withdraw(route);
  pending_.clear();
}

std::vector<Route> RouteReconciler::routes() const {
  std::lock_guard lock(mutex_);
  std::vector<Route> out;
  out.reserve(routes_.size());
  for (const auto& [key, route] : routes_) out.push_back(route);
  return out;
}

}  // namespace urs::bridge::core
