#pragma once
// RouteReconciler: from what one side offers now and a direction's rules, the routes that must
// exist towards another side, made and withdrawn through that side's ServiceOffering capability
// (urs/bridge/core/side.hpp), each stand-in's calls served by the source side (ServiceSource).
//
// A route is one offer of the source side standing as a service of the target side. Each call of
// reconcile() takes the source's complete current offers and
//   - withdraws the routes whose offer vanished, no longer matches a rule, or changed revision;
//   - offers what a rule admits (and the direction's name filter lets through under the name the
//     rule gives it) and is not routed yet, skipping what is not bridgeable (loop
//     prevention: offers carrying an origin, built-ins); an offer the target refused is tried again
//     after the retry period, and logged once until it succeeds;
//   - gives a stand-in name to one offer only: the one routed already keeps it, else the least key;
//     the others wait (refused "duplicate") until the name is free;
//   - updates the routes whose offer's properties changed.
// target_restarted() is for a target that may have lost what it offered (a restart, a cut after
// which others forget it): at the next reconcile() every route still wanted is offered again
// (without a withdraw first) and the others withdrawn. Nothing here blocks but the target's calls.
//
// Threads: reconcile(), target_restarted() and withdraw_all() from one thread; routes() from any.

#include <chrono>
#include <map>
#include <mutex>
#include <set>
#include <string>
#include <vector>

#include "urs/bridge/core/offer.hpp"
#include "urs/bridge/core/rules.hpp"
#include "urs/bridge/core/side.hpp"

namespace urs::bridge::core {

// An offer of one side standing as a service of another.
struct Route {
  Offer offer;               // as the source side last reported it
  std::string name;          // the stand-in's name on the target side
  uint32_t deadline_ms = 0;  // of the rule that admitted it
};

class RouteReconciler {
 public:
  using Clock = std::chrono::steady_clock;

  // `direction` names the routes in logs ("camus -> rt"); `source` and `target` outlive the
  // reconciler. A route's stand-in name must also pass `names` (allow/deny globs).
  RouteReconciler(std::string direction, std::vector<RouteRule> rules, ServiceSource& source, ServiceOffering& target,
                  std::chrono::milliseconds retry_period, NameFilter names = {});
  RouteReconciler(const RouteReconciler&) = delete;
  RouteReconciler& operator=(const RouteReconciler&) = delete;

  struct Changes {
    std::vector<std::string> offered;    // stand-in names offered by this call
    std::vector<std::string> withdrawn;  // stand-in names withdrawn by this call
    std::vector<std::string> updated;
    std::map<std::string, std::string> refused;  // offer key -> why (refusals and duplicates)
  };
  // Brings the routes in line with `offers` (the source side's complete list, keys unique).
  Changes reconcile(const std::vector<Offer>& offers, Clock::time_point now = Clock::now());
  // The target may have lost its stand-ins: those still wanted are offered again at the next reconcile().
  void target_restarted();
  // Withdraws every route (the bridge stops, or the source side is gone).
  void withdraw_all();

  std::vector<Route> routes() const;  // by offer key
  const std::string& direction() const { return direction_; }

 private:
  struct Pending {
    Clock::time_point retry_at;
    std::string reason;  // last refusal, logged once
  };

  const std::string direction_;
  const std::vector<RouteRule> rules_;
  const NameFilter names_;
  ServiceSource& source_;
  ServiceOffering& target_;
  const std::chrono::milliseconds retry_period_;

  mutable std::mutex mutex_;                // guards routes_ (routes() reads it from other threads)
  std::map<std::string, Route> routes_;     // by offer key: what the target offers now
  std::map<std::string, Pending> pending_;  // offers refused, by key
  bool restarted_ = false;
};

}  // namespace urs::bridge::core
