// The real core::Bridge driven with in-memory sides (memory_side.hpp), registered as the real sides
// are: offers appearing and leaving, calls in both directions, failures passed on with their
// status, rules and name filters, loops, sides that cannot open yet, restarts, state and streams.

#include "urs/bridge/core/bridge.hpp"

#include <gtest/gtest.h>

#include "memory_side.hpp"
#include "urs/util/error.hpp"

namespace urs::bridge::test {
namespace {

using core::Bridge;
using core::BridgeLayout;
using core::DirectionConfig;

core::RouteRule rule(std::vector<std::string> allow, std::string name, std::vector<std::string> deny = {}) {
  core::RouteRule out;
  out.allow = std::move(allow);
  out.deny = std::move(deny);
  out.name = std::move(name);
  out.deadline_ms = 2000;
  return out;
}

DirectionConfig direction(std::string from, std::string to,
                          std::vector<core::RouteRule> rules = {rule({"*"}, "{name}")},
                          std::chrono::milliseconds period = 20ms) {
  DirectionConfig out;
  out.from = std::move(from);
  out.to = std::move(to);
  out.rules = std::move(rules);
  out.period = period;
  out.retry = 20ms;
  return out;
}

BridgeLayout layout_of(std::vector<DirectionConfig> directions) {
  BridgeLayout layout;
  layout.directions = std::move(directions);
  return layout;
}

// Two memory sides "a" and "b" and a bridge between them, made like urs-bridge makes its own.
class BridgeWithMemorySides : public ::testing::Test {
 protected:
  void make(BridgeLayout layout, bool a_drives = false) {
    auto a = std::make_unique<MemorySide>("a", a_drives);
    auto b = std::make_unique<MemorySide>("b");
    a_ = a.get();
    b_ = b.get();
    configure_(*a, *b);
    std::vector<std::unique_ptr<core::Side>> sides;
    sides.push_back(std::move(a));
    sides.push_back(std::move(b));
    layout.open_retry = 20ms;
    bridge_ = std::make_unique<Bridge>("test", std::move(sides), std::move(layout));
    bridge_->start();
  }
  void TearDown() override {
    if (bridge_) bridge_->shutdown();
  }

  std::function<void(MemorySide&, MemorySide&)> configure_ = [](MemorySide&, MemorySide&) {};
  MemorySide* a_ = nullptr;
  MemorySide* b_ = nullptr;
  std::unique_ptr<Bridge> bridge_;
};

TEST_F(BridgeWithMemorySides, AnOfferAppearsAsAStandInAndLeavesWithIt) {
  make(layout_of({direction("a", "b")}));
  a_->add_own("diag");
  ASSERT_TRUE(b_->wait_for([&] { return b_->holds("diag"); }));
  EXPECT_EQ(b_->stand_in("diag").offer.source, "a:diag");

  a_->remove_own("diag");
  EXPECT_TRUE(b_->wait_for([&] { return !b_->holds("diag"); }));
}

TEST_F(BridgeWithMemorySides, AChangeAnnouncedIsRoutedBeforeThePeriod) {
  make(layout_of({direction("a", "b", {rule({"*"}, "{name}")}, std::chrono::hours(1))}));
  ASSERT_TRUE(b_->wait_for([&] { return b_->is_open(); }));
  a_->add_own("diag");
  a_->announce_change();  // the period is an hour: only the notification brings it
  EXPECT_TRUE(b_->wait_for([&] { return b_->holds("diag"); }));
}

TEST_F(BridgeWithMemorySides, CallsGoThroughTheStandInsBothWays) {
  make(layout_of(
      {direction("a", "b", {rule({"*"}, "from-a.{name}")}), direction("b", "a", {rule({"*"}, "from-b.{name}")})}));
  a_->add_own("diag");
  b_->add_own("tts");
  ASSERT_TRUE(b_->wait_for([&] { return b_->holds("from-a.diag"); }));
  ASSERT_TRUE(a_->wait_for([&] { return a_->holds("from-b.tts"); }));

  const call::Reply to_a = b_->call("from-a.diag", "echo", echo_request("hi"));
  ASSERT_TRUE(to_a.ok()) << to_a.message;
  EXPECT_EQ(echoed(to_a), "a:hi");
  const call::Reply to_b = a_->call("from-b.tts", "echo", echo_request("ho"));
  ASSERT_TRUE(to_b.ok()) << to_b.message;
  EXPECT_EQ(echoed(to_b), "b:ho");
}

TEST_F(BridgeWithMemorySides, NothingABridgeMadeIsBridgedBack) {
  make(layout_of({direction("a", "b"), direction("b", "a")}));
  a_->add_own("diag");
  ASSERT_TRUE(b_->wait_for([&] { return b_->holds("diag"); }));
  // Several periods of both directions: b's stand-in carries an origin, so a gets nothing back.
  EXPECT_FALSE(a_->wait_for([&] { return !a_->stand_ins().empty(); }, 200ms));
  EXPECT_EQ(b_->locked_stand_ins(), (std::set<std::string>{"diag"}));
}

TEST_F(BridgeWithMemorySides, ADirectionCarriesOnlyWhatItsRulesAndFilterAdmit) {
  DirectionConfig to_b = direction("a", "b", {rule({"diag*"}, "lab.{name}", {"diag.secret"})});
  to_b.names.deny = {"lab.diag.hidden"};
  make(layout_of({to_b}));
  for (const char* name : {"diag", "diag.secret", "diag.hidden", "tts"}) a_->add_own(name);
  a_->announce_change();
  ASSERT_TRUE(b_->wait_for([&] { return b_->holds("lab.diag"); }));
  // More periods change nothing.
  EXPECT_FALSE(b_->wait_for([&] { return b_->stand_ins().size() > 1; }, 200ms));
  EXPECT_EQ(b_->locked_stand_ins(), (std::set<std::string>{"lab.diag"}));
}

TEST_F(BridgeWithMemorySides, FailuresReachTheCallerWithTheirStatus) {
  make(layout_of({direction("a", "b")}));
  a_->add_own("gone", [](const call::Request&) {
    return call::Reply::error(call::Status::PROVIDER_GONE, "the provider left");
  });
  a_->add_own("busy", [](const call::Request&) {
    return call::Reply::error(call::Status::RESOURCE_EXHAUSTED, "queue (16) is full");
  });
  a_->add_own("raises", [](const call::Request&) {
    URS::Failure failure;
    failure.set_reason("jammed");
    failure.set_code(9);
    return call::Reply::user_exception("URS.Failure", failure.SerializeAsString(), "jammed");
  });
  a_->add_own("odd", [](const call::Request&) {
    return call::Reply::user_exception("URS.Unknown", "", "an exception fail() does not declare");
  });
  ASSERT_TRUE(b_->wait_for([&] { return b_->stand_ins().size() == 4; }));

  const call::Reply gone = b_->call("gone", "echo", echo_request("x"));
  EXPECT_EQ(gone.status, call::Status::PROVIDER_GONE);
  EXPECT_EQ(gone.message, "the provider left");
  const call::Reply busy = b_->call("busy", "echo", echo_request("x"));
  EXPECT_EQ(busy.status, call::Status::RESOURCE_EXHAUSTED);
  EXPECT_EQ(busy.message, "queue (16) is full");

  URS::Diagnostic_fail_Request fail;
  fail.set_reason("jammed");
  fail.set_code(9);
  const call::Reply raised = b_->call("raises", "fail", fail.SerializeAsString());
  ASSERT_EQ(raised.status, call::Status::USER_EXCEPTION) << raised.message;
  EXPECT_EQ(raised.exception_type, "URS.Failure");
  URS::Failure failure;
  ASSERT_TRUE(failure.ParseFromString(raised.payload));
  EXPECT_EQ(failure.reason(), "jammed");
  EXPECT_EQ(failure.code(), 9);

  const call::Reply odd = b_->call("odd", "fail", fail.SerializeAsString());
  EXPECT_EQ(odd.status, call::Status::INTERNAL);
  EXPECT_EQ(odd.message, "odd.fail raised URS.Unknown, which it does not declare");

  const call::Reply missing = b_->call("gone", "no_such_operation", "");
  EXPECT_EQ(missing.status, call::Status::UNKNOWN_OPERATION);
}

TEST_F(BridgeWithMemorySides, ARefusedStandInIsTriedAgainUntilItIsTaken) {
  configure_ = [](MemorySide&, MemorySide& b) { b.refuse({"diag"}); };
  make(layout_of({direction("a", "b")}));
  a_->add_own("diag");
  a_->add_own("tts");
  ASSERT_TRUE(b_->wait_for([&] { return b_->holds("tts"); }));
  // Refused, then offered again at each retry (20 ms here) while the refusal lasts.
  ASSERT_TRUE(b_->wait_for([&] { return b_->offer_attempts() >= 4; }));
  EXPECT_FALSE(b_->locked_stand_ins().count("diag"));
  b_->refuse({});
  EXPECT_TRUE(b_->wait_for([&] { return b_->holds("diag"); }));
}

TEST_F(BridgeWithMemorySides, AServiceGoneFromItsSideAnswersUnknownServiceThroughItsStandIn) {
  make(layout_of({direction("a", "b", {rule({"*"}, "{name}")}, std::chrono::hours(1))}));
  a_->add_own("tts");
  a_->announce_change();
  ASSERT_TRUE(b_->wait_for([&] { return b_->holds("tts"); }));
  // The source forgets the service; with a period of an hour and no notification the stand-in
  // stays, and its calls answer as the source does.
  a_->remove_own("tts");
  const call::Reply late = b_->call("tts", "echo", echo_request("x"));
  EXPECT_EQ(late.status, call::Status::UNKNOWN_SERVICE) << late.message;
  EXPECT_EQ(late.message, "a has no service tts");
}

TEST_F(BridgeWithMemorySides, ASideThatCannotOpenYetIsTriedAgainAndTheOthersWork) {
  configure_ = [](MemorySide&, MemorySide& b) { b.open_failures = 3; };
  make(layout_of({direction("a", "b")}));
  a_->add_own("diag");
  ASSERT_TRUE(b_->wait_for([&] { return b_->holds("diag"); }));
  EXPECT_EQ(b_->opened(), 1);
  EXPECT_TRUE(a_->is_open());
}

TEST_F(BridgeWithMemorySides, ASideThatLostItsStandInsGetsThemAgain) {
  make(layout_of({direction("a", "b", {rule({"*"}, "{name}")}, std::chrono::hours(1))}));
  a_->add_own("diag");
  a_->announce_change();
  ASSERT_TRUE(b_->wait_for([&] { return b_->holds("diag"); }));
  b_->lose_stand_ins();
  EXPECT_TRUE(b_->wait_for([&] { return b_->holds("diag"); }));
  EXPECT_EQ(b_->offered(), 2);
}

TEST_F(BridgeWithMemorySides, ASideThatAsksToBeOpenedAgainIsClosedAndOpenedWithItsRoutesAndFlows) {
  BridgeLayout layout = layout_of({direction("a", "b")});
  layout.state = {{"b", "a"}};
  make(std::move(layout));
  a_->add_own("diag");
  ASSERT_TRUE(b_->wait_for([&] { return b_->holds("diag") && b_->state_wired(); }));
  b_->ask_to_reopen();
  EXPECT_TRUE(b_->wait_for([&] { return b_->opened() == 2 && b_->holds("diag") && b_->state_wired(); }));
  EXPECT_EQ(b_->offered(), 2);  // withdrawn from the old session, offered on the new one
  EXPECT_EQ(a_->opened(), 1);   // the other side kept its session
  EXPECT_EQ(b_->call("diag", "echo", echo_request("x")).status, call::Status::OK);
}

TEST_F(BridgeWithMemorySides, ASourceThatCannotSayKeepsItsRoutes) {
  make(layout_of({direction("a", "b")}));
  a_->add_own("diag");
  ASSERT_TRUE(b_->wait_for([&] { return b_->holds("diag"); }));
  a_->silent = true;
  a_->remove_own("diag");  // not seen: the source cannot say
  EXPECT_FALSE(b_->wait_for([&] { return !b_->holds("diag"); }, 200ms));
  a_->silent = false;
  EXPECT_TRUE(b_->wait_for([&] { return !b_->holds("diag"); }));
}

TEST_F(BridgeWithMemorySides, ADrivingSideMakesTheBridgeActiveAndInactive) {
  make(layout_of({direction("a", "b")}), /*a_drives=*/true);
  a_->add_own("diag");
  EXPECT_FALSE(b_->wait_for([&] { return b_->is_open(); }, 100ms));  // inactive until a says so
  a_->set_active(true);
  ASSERT_TRUE(b_->wait_for([&] { return b_->holds("diag"); }));
  a_->set_active(false);  // every route withdrawn, every side closed
  EXPECT_TRUE(b_->wait_for([&] { return !b_->holds("diag") && !b_->is_open(); }));
  EXPECT_FALSE(bridge_->status().active);
}

TEST_F(BridgeWithMemorySides, StateAndStreamsFlowWhereTheLayoutSays) {
  BridgeLayout layout;
  layout.state = {{"a", "b"}};
  layout.streams = {{"b", "a"}};
  make(std::move(layout));
  ASSERT_TRUE(a_->wait_for([&] { return a_->state_wired(); }));
  core::StateEvent event;
  event.topic = "robot1/arrived";
  ASSERT_TRUE(a_->emit_event(event));
  EXPECT_TRUE(b_->wait_for([&] { return b_->events.size() == 1 && b_->events[0].topic == "robot1/arrived"; }));
  ASSERT_TRUE(b_->wait_for([&] { return b_->stream_wired(); }));
  ASSERT_TRUE(b_->emit_value(3, "pose"));
  EXPECT_TRUE(a_->wait_for([&] {
    return a_->written == std::vector<std::pair<std::size_t, std::string>>{{3, "pose"}};
  }));
  bridge_->shutdown();  // the flows end before the sides close
  EXPECT_FALSE(a_->emit_event(event));
}

TEST(BridgeLayoutTest, ADirectionOrFlowNamingNoSideIsAConfigurationError) {
  std::vector<std::unique_ptr<core::Side>> sides;
  sides.push_back(std::make_unique<MemorySide>("a"));
  BridgeLayout layout;
  layout.directions = {direction("a", "ros2")};
  layout.state = {{"mqtt", "a"}};
  try {
    Bridge bridge("test", std::move(sides), std::move(layout));
    FAIL() << "a layout naming absent sides was taken";
  } catch (const util::ConfigError& e) {
    const std::string text = e.what();
    EXPECT_NE(text.find("direction a -> ros2: no side ros2 is configured"), std::string::npos) << text;
    EXPECT_NE(text.find("state mqtt -> a: no side mqtt is configured"), std::string::npos) << text;
  }
}

}  // namespace
}  // namespace urs::bridge::test
