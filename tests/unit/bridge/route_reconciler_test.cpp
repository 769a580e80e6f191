// The bridge's core without middleware: the routes a RouteReconciler makes between two in-memory
// sides from their offers and the rules (creation, withdrawal, loop prevention, rule matching and
// name templates, restarts, refusals retried, duplicate names).

#include "urs/bridge/core/route_reconciler.hpp"

#include <gtest/gtest.h>

#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

namespace urs::bridge::core {
namespace {

using namespace std::chrono_literals;
using Clock = RouteReconciler::Clock;

Offer make_offer(const std::string& key, const std::string& name, const std::string& interface_name,
                 std::vector<std::pair<std::string, std::string>> fields = {}) {
  Offer offer;
  offer.key = key;
  offer.name = name;
  offer.interface_name = interface_name;
  offer.fields = std::move(fields);
  offer.source = "memory:" + key;
  return offer;
}

// The source of every route here: the reconciler hands it to the target's offer(), which (below)
// records the route without asking it for calls.
class NoCalls : public ServiceSource {
 public:
  std::string kind() const override { return "Memory"; }
  std::optional<std::vector<Offer>> offers() override { return std::vector<Offer>{}; }
  std::shared_ptr<agent::ServiceAgent> serve(const Route&) override { return nullptr; }
};
NoCalls no_calls;

// One side of the bridge held in memory: its own services, and the stand-ins a reconciler offers
// on it (which carry an origin, as the real adapters' do).
class MemorySide : public ServiceOffering {
 public:
  explicit MemorySide(std::string side) : side_(std::move(side)) {}

  void add_own(const std::string& name, const std::string& interface_name = "Demo::Echo") {
    own_[name] = make_offer(name, name, interface_name);
  }
  void remove_own(const std::string& name) { own_.erase(name); }
  Offer& own(const std::string& name) { return own_.at(name); }

  // What this side offers now: its own services and the stand-ins offered on it.
  std::vector<Offer> offers() const {
    std::vector<Offer> out;
    for (const auto& [name, offer] : own_) out.push_back(offer);
    for (const auto& [name, route] : stand_ins_) {
      Offer stand_in = make_offer(name, name, route.offer.interface_name);
      stand_in.origin = route.offer.source;  // as the real sides mark what they offer for a bridge
      out.push_back(stand_in);
    }
    return out;
  }
  bool holds(const std::string& name) const { return stand_ins_.count(name) > 0; }
  const Route& stand_in(const std::string& name) const { return stand_ins_.at(name); }
  std::set<std::string> names() const {
    std::set<std::string> out;
    for (const auto& [name, route] : stand_ins_) out.insert(name);
    return out;
  }
  // Loses every stand-in, as a restarted server does.
  void restart() { stand_ins_.clear(); }

  std::set<std::string> refusing;  // names offer() refuses
  int offered = 0, withdrawn = 0, updated = 0;

  // ServiceOffering
  OfferOutcome offer(const Route& route, ServiceSource&) override {
    if (refusing.count(route.name)) return OfferOutcome::refuse(route.name + " is refused by " + side_);
    EXPECT_EQ(stand_ins_.count(route.name), 0u) << route.name << " offered twice on " << side_;
    stand_ins_[route.name] = route;
    ++offered;
    return OfferOutcome::done();
  }
  void withdraw(const Route& route) override {
    EXPECT_EQ(stand_ins_.erase(route.name), 1u) << route.name << " withdrawn but not offered on " << side_;
    ++withdrawn;
  }
  void update(const Route& route) override {
    stand_ins_.at(route.name) = route;
    ++updated;
  }
  std::string usable_name(const std::string& name) const override {
    std::string out = name;
    for (char& c : out) {
      if (c == ' ') c = '_';
    }
    return out;
  }

 private:
  const std::string side_;
  std::map<std::string, Offer> own_;
  std::map<std::string, Route> stand_ins_;
};

RouteRule rule(std::vector<std::string> allow, std::string name, std::vector<std::string> deny = {}) {
  RouteRule out;
  out.allow = std::move(allow);
  out.deny = std::move(deny);
  out.name = std::move(name);
  return out;
}

// Routes every offer to `target` under its own name.
RouteReconciler route_everything(ServiceOffering& target, const std::string& direction = "CAMUS -> RT") {
  return RouteReconciler(direction, {rule({"*"}, "{name}")}, no_calls, target, 10s);
}

TEST(BridgeCoreTest, OffersWhatTheRulesAdmitUnderTheirTemplate) {
  MemorySide camus("camus"), rt("rt");
  camus.add_own("tts");
  camus.add_own("nav");
  camus.add_own("secret");
  RouteReconciler routes("CAMUS -> RT", {rule({"*"}, "Camus{name}", {"secret"})}, no_calls, rt, 10s);

  const auto changes = routes.reconcile(camus.offers());

  EXPECT_EQ(rt.names(), (std::set<std::string>{"Camusnav", "Camustts"}));
  EXPECT_EQ(changes.offered, (std::vector<std::string>{"Camusnav", "Camustts"}));
  EXPECT_EQ(rt.stand_in("Camustts").offer.key, "tts");
  EXPECT_EQ(rt.stand_in("Camustts").deadline_ms, 10000u);
  ASSERT_EQ(routes.routes().size(), 2u);
  EXPECT_EQ(routes.routes()[0].name, "Camusnav");
}

TEST(BridgeCoreTest, AStableOfferIsOfferedOnce) {
  MemorySide camus("camus"), rt("rt");
  camus.add_own("tts");
  RouteReconciler routes = route_everything(rt);
  routes.reconcile(camus.offers());
  const auto again = routes.reconcile(camus.offers());
  EXPECT_TRUE(again.offered.empty());
  EXPECT_TRUE(again.withdrawn.empty());
  EXPECT_EQ(rt.offered, 1);
}

TEST(BridgeCoreTest, WithdrawsWhatVanished) {
  MemorySide camus("camus"), rt("rt");
  camus.add_own("tts");
  camus.add_own("nav");
  RouteReconciler routes = route_everything(rt);
  routes.reconcile(camus.offers());

  camus.remove_own("tts");
  const auto changes = routes.reconcile(camus.offers());

  EXPECT_EQ(changes.withdrawn, (std::vector<std::string>{"tts"}));
  EXPECT_EQ(rt.names(), (std::set<std::string>{"nav"}));
  routes.withdraw_all();
  EXPECT_TRUE(rt.names().empty());
  EXPECT_TRUE(routes.routes().empty());
}

TEST(BridgeCoreTest, NothingCarryingAnOriginNorABuiltInIsBridged) {
  MemorySide camus("camus");
  camus.add_own("tts");
  camus.add_own("camus.registry");
  camus.own("camus.registry").built_in = true;
  camus.add_own("jp/tts");
  camus.own("jp/tts").origin = "dds:jp/tts";
  MemorySide rt("rt");
  RouteReconciler routes = route_everything(rt);
  routes.reconcile(camus.offers());
  EXPECT_EQ(rt.names(), (std::set<std::string>{"tts"}));
}

TEST(BridgeCoreTest, TwoDirectionsBetweenTheSameSidesMakeNoLoop) {
  MemorySide camus("camus"), rt("rt");
  camus.add_own("tts");
  rt.add_own("Robot0.nav");
  RouteReconciler to_rt = route_everything(rt);
  RouteReconciler to_camus = route_everything(camus, "RT -> CAMUS");
  for (int round = 0; round < 3; ++round) {
    to_rt.reconcile(camus.offers());
    to_camus.reconcile(rt.offers());
  }
  EXPECT_EQ(rt.names(), (std::set<std::string>{"tts"}));
  EXPECT_EQ(camus.names(), (std::set<std::string>{"Robot0.nav"}));
  EXPECT_EQ(rt.offered + camus.offered, 2);
}

TEST(BridgeCoreTest, TheFirstMatchingRuleNamesTheStandIn) {
  MemorySide rt("rt"), camus("camus");
  const Offer nav =
      make_offer("c1|nav", "lab.host_cxt/Robot0.rtc", "URC::Navigation", {{"instance", "Robot0"}, {"port", "nav"}});
  const Offer arm =
      make_offer("c2|arm", "lab.host_cxt/Arm0.rtc", "URC::Manipulator", {{"instance", "Arm0"}, {"port", "arm"}});
  const Offer other =
      make_offer("c3|x", "lab.host_cxt/Other.rtc", "URC::Navigation", {{"instance", "Other"}, {"port", "x"}});
  RouteRule navigation = rule({"*/Robot*.rtc"}, "robot.{instance}.{port}");
  navigation.interface = "URC::Navigation";
  navigation.deadline_ms = 500;
  RouteRule any_arm = rule({"*/*.rtc"}, "{instance}");
  any_arm.interface = "URC::Manipulator";
  RouteReconciler routes("RT -> CAMUS", {navigation, any_arm}, no_calls, camus, 10s);

  routes.reconcile({nav, arm, other});

  EXPECT_EQ(camus.names(), (std::set<std::string>{"Arm0", "robot.Robot0.nav"}));
  EXPECT_EQ(camus.stand_in("robot.Robot0.nav").deadline_ms, 500u);
}

TEST(BridgeCoreTest, RuleMatchingAndTemplates) {
  const Offer remote = make_offer("jp/tts", "jp/tts", "Demo::Speech", {{"space", "jp"}, {"service", "tts"}});
  const RouteRule as_camus = rule({"jp/*"}, "{space}/{service}", {"*/secret*"});
  const std::vector<RouteRule> rules{rule({"kr/*"}, "kr.{service}"), as_camus};
  EXPECT_EQ(first_match(rules, remote), &rules[1]);
  EXPECT_EQ(stand_in_name(as_camus, remote), "jp/tts");
  EXPECT_EQ(stand_in_name(rule({"*"}, "{space}_{service}_{unknown}"), remote), "jp_tts_{unknown}");
  EXPECT_EQ(stand_in_name(rule({"*"}, "{name}.{name}"), remote), "jp/tts.jp/tts");
  Offer secret = remote;
  secret.name = "jp/secret-plan";
  EXPECT_EQ(first_match(rules, secret), nullptr);
  Offer elsewhere = remote;
  elsewhere.name = "cn/tts";
  EXPECT_EQ(first_match(rules, elsewhere), nullptr);
  EXPECT_TRUE(glob_match("*/Robot?.rtc", "a.host_cxt/sub/Robot1.rtc"));  // '*' crosses '/'
  EXPECT_FALSE(allowed("x", {}, {}));                                    // nothing allowed by default
}

TEST(BridgeCoreTest, TheTargetSideMakesTheNameUsable) {
  MemorySide camus("camus"), rt("rt");
  camus.add_own("text to speech");
  RouteReconciler routes = route_everything(rt);
  routes.reconcile(camus.offers());
  EXPECT_EQ(rt.names(), (std::set<std::string>{"text_to_speech"}));
}

TEST(BridgeCoreTest, ADisputedNameGoesToOneOfferAndPassesOnWhenItLeaves) {
  MemorySide camus("camus"), rt("rt");
  camus.add_own("b.tts");
  camus.add_own("a.tts");
  camus.own("a.tts").fields = {{"short", "tts"}};
  camus.own("b.tts").fields = {{"short", "tts"}};
  RouteReconciler routes("CAMUS -> RT", {rule({"*"}, "{short}")}, no_calls, rt, 10s);
  const auto t0 = Clock::now();

  const auto first = routes.reconcile(camus.offers(), t0);
  EXPECT_EQ(rt.stand_in("tts").offer.key, "a.tts");  // the least key
  ASSERT_EQ(first.refused.count("b.tts"), 1u);
  EXPECT_EQ(first.refused.at("b.tts"), "the name is taken by a.tts");

  camus.add_own("0.tts");  // a newcomer does not take the name from the one routed
  camus.own("0.tts").fields = {{"short", "tts"}};
  routes.reconcile(camus.offers(), t0);
  EXPECT_EQ(rt.stand_in("tts").offer.key, "a.tts");

  camus.remove_own("a.tts");
  const auto after = routes.reconcile(camus.offers(), t0);  // no retry period for a name freed
  EXPECT_EQ(after.withdrawn, (std::vector<std::string>{"tts"}));
  EXPECT_EQ(after.offered, (std::vector<std::string>{"tts"}));
  EXPECT_EQ(rt.stand_in("tts").offer.key, "0.tts");
}

TEST(BridgeCoreTest, ARefusedOfferIsTriedAgainAfterTheRetryPeriod) {
  MemorySide camus("camus"), rt("rt");
  camus.add_own("tts");
  rt.refusing.insert("tts");
  RouteReconciler routes = route_everything(rt);
  const auto t0 = Clock::now();

  const auto refused = routes.reconcile(camus.offers(), t0);
  EXPECT_EQ(refused.refused.at("tts"), "tts is refused by rt");
  rt.refusing.clear();
  routes.reconcile(camus.offers(), t0 + 5s);
  EXPECT_FALSE(rt.holds("tts"));  // not before the period
  routes.reconcile(camus.offers(), t0 + 10s);
  EXPECT_TRUE(rt.holds("tts"));
}

TEST(BridgeCoreTest, ARestartedTargetIsOfferedEverythingAgain) {
  MemorySide camus("camus"), rt("rt");
  camus.add_own("tts");
  camus.add_own("nav");
  RouteReconciler routes = route_everything(rt);
  routes.reconcile(camus.offers());

  rt.restart();
  routes.target_restarted();
  const auto changes = routes.reconcile(camus.offers());

  EXPECT_TRUE(changes.withdrawn.empty());  // the target holds nothing to withdraw
  EXPECT_EQ(rt.names(), (std::set<std::string>{"nav", "tts"}));
  EXPECT_EQ(rt.offered, 4);
}

TEST(BridgeCoreTest, ARestartedSourceIsRoutedAgainUnderTheSameNames) {
  MemorySide camus("camus"), rt("rt");
  camus.add_own("tts");
  RouteReconciler routes = route_everything(rt);
  routes.reconcile(camus.offers());
  camus.remove_own("tts");  // the server restarted: its registry is empty a while
  routes.reconcile(camus.offers());
  EXPECT_FALSE(rt.holds("tts"));
  camus.add_own("tts");
  routes.reconcile(camus.offers());
  EXPECT_TRUE(rt.holds("tts"));
}

TEST(BridgeCoreTest, ANewRevisionIsRoutedAgainAndNewPropertiesUpdated) {
  MemorySide dds("dds"), camus("camus");
  dds.add_own("jp/tts");
  RouteReconciler routes = route_everything(camus, "DDS -> CAMUS");
  routes.reconcile(dds.offers());

  dds.own("jp/tts").properties["urslink.health"] = "slow";
  const auto updated = routes.reconcile(dds.offers());
  EXPECT_EQ(updated.updated, (std::vector<std::string>{"jp/tts"}));
  EXPECT_EQ(camus.stand_in("jp/tts").offer.properties.at("urslink.health"), "slow");
  EXPECT_EQ(camus.offered, 1);

  dds.own("jp/tts").revision = "description 2";
  const auto remade = routes.reconcile(dds.offers());
  EXPECT_EQ(remade.withdrawn, (std::vector<std::string>{"jp/tts"}));
  EXPECT_EQ(remade.offered, (std::vector<std::string>{"jp/tts"}));
  EXPECT_EQ(camus.stand_in("jp/tts").offer.revision, "description 2");
}

}  // namespace
}  // namespace urs::bridge::core
