#include "urs/camus_server/router.hpp"

#include <gtest/gtest.h>

#include <condition_variable>
#include <map>
#include <mutex>

#include "fakes.hpp"

namespace urs::camus_server::test {
namespace {

class NoContainer final : public ServiceContainer {
 public:
  bool hosts(const std::string&) const override { return false; }
  void dispatch(const planet::Request&, const Caller&, Completion) override {}
};

class RouterTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(registry.register_service(provider, navigation_registration("robot1.navigation")).ok());
    const auto* file = camus::ServiceInfo::descriptor()->file();
    registry.add_builtin("camus.registry", *file->FindServiceByName("Registry"));
  }

  planet::Request request(uint64_t call_id, const std::string& service, const std::string& op, uint64_t deadline_ms = 0,
                          bool oneway = false) {
    planet::Request r;
    r.set_call_id(call_id);
    r.set_service(service);
    r.set_operation(op);
    r.set_payload("args");
    r.set_deadline_ms(deadline_ms);
    r.set_oneway(oneway);
    return r;
  }

  planet::Reply reply_from_provider(uint64_t server_call_id, const std::string& payload) {
    planet::Reply reply;
    reply.set_call_id(server_call_id);
    reply.set_status(planet::OK);
    reply.set_payload(payload);
    return reply;
  }

  RecordingSink sink;
  Registry registry{"kr", sink};
  RegistryService registry_service{registry};
  NoContainer container;
  BuiltinServices builtins{registry_service, container};
  ManualScheduler timers;
  static RouterOptions options() {
    RouterOptions o;
    o.space = "kr";
    o.default_deadline = std::chrono::milliseconds(1000);
    o.max_deadline_ms = 60000;
    o.max_pending_calls = 5;
    o.max_pending_calls_per_session = 3;
    return o;
  }
  Router router{options(), registry, builtins, timers};
  std::shared_ptr<FakeSession> caller = std::make_shared<FakeSession>(1, "cli@host", planet::CLIENT);
  std::shared_ptr<FakeSession> provider = std::make_shared<FakeSession>(2, "sam@robot1", planet::SAM);
};

TEST_F(RouterTest, ForwardsWithServerCallIdAndMapsTheReplyBack) {
  router.on_request(caller, request(7, "robot1.navigation", "moveTo"));
  router.on_request(caller, request(8, "robot1.navigation", "moveTo"));
  ASSERT_EQ(provider->count(planet::Frame::kRequest), 2u);
  auto first = provider->frames()[0].request();
  auto second = provider->frames()[1].request();
  EXPECT_NE(first.call_id(), second.call_id());
  EXPECT_EQ(first.service(), "robot1.navigation");
  EXPECT_EQ(first.operation(), "moveTo");
  EXPECT_EQ(first.payload(), "args");
  EXPECT_EQ(first.deadline_ms(), 1000u);         // the server default, passed on to the provider
  EXPECT_EQ(first.caller().name(), "cli@host");  // who calls, as the server authenticated it
  EXPECT_EQ(first.caller().role(), planet::CLIENT);
  EXPECT_EQ(router.pending(), 2u);

  router.on_reply(*provider, reply_from_provider(second.call_id(), "second"));
  router.on_reply(*provider, reply_from_provider(first.call_id(), "first"));
  ASSERT_EQ(caller->count(planet::Frame::kReply), 2u);
  auto r0 = caller->frames()[0].reply();
  auto r1 = caller->frames()[1].reply();
  EXPECT_EQ(r0.call_id(), 8u);
  EXPECT_EQ(r1.call_id(), 7u);
  EXPECT_EQ(r0.payload(), "second");
  EXPECT_EQ(r1.payload(), "first");
  EXPECT_EQ(router.pending(), 0u);
  EXPECT_EQ(timers.pending(), 0u);  // deadline timers cancelled
}

TEST_F(RouterTest, ARequestNamingItsOwnCallerIsRefused) {
  planet::Request forged = request(4, "robot1.navigation", "moveTo");
  forged.mutable_caller()->set_name("ops");
  forged.mutable_caller()->set_role(planet::OPERATOR);
  router.on_request(caller, forged);
  EXPECT_EQ(provider->count(planet::Frame::kRequest), 0u);
  auto got = caller->wait_frame(planet::Frame::kReply);
  ASSERT_TRUE(got);
  EXPECT_EQ(got->reply().call_id(), 4u);
  EXPECT_EQ(got->reply().status(), planet::PERMISSION_DENIED);
  EXPECT_EQ(got->reply().message(),
            "Request.caller is set by the server alone: robot1.navigation.moveTo not called (a client may not name "
            "who calls)");
  EXPECT_EQ(router.pending(), 0u);
}

TEST_F(RouterTest, ProviderStatusAndExceptionArePassedThrough) {
  router.on_request(caller, request(3, "robot1.navigation", "moveTo"));
  planet::Reply reply;
  reply.set_call_id(provider->frames()[0].request().call_id());
  reply.set_status(planet::USER_EXCEPTION);
  reply.set_message("target outside the map");
  reply.set_exception_type("URC.InvalidTarget");
  reply.set_payload("exc");
  router.on_reply(*provider, reply);
  auto got = caller->wait_frame(planet::Frame::kReply);
  ASSERT_TRUE(got);
  EXPECT_EQ(got->reply().status(), planet::USER_EXCEPTION);
  EXPECT_EQ(got->reply().message(), "target outside the map");
  EXPECT_EQ(got->reply().exception_type(), "URC.InvalidTarget");
  EXPECT_EQ(got->reply().payload(), "exc");
}

TEST_F(RouterTest, DeadlineExceededThenLateReplyIsDropped) {
  router.on_request(caller, request(9, "robot1.navigation", "moveTo", 250));
  uint64_t server_id = provider->frames()[0].request().call_id();
  EXPECT_EQ(provider->frames()[0].request().deadline_ms(), 250u);
  timers.advance(std::chrono::milliseconds(249));
  EXPECT_EQ(caller->count(planet::Frame::kReply), 0u);
  timers.advance(std::chrono::milliseconds(1));
  ASSERT_EQ(caller->count(planet::Frame::kReply), 1u);
  auto reply = caller->frames()[0].reply();
  EXPECT_EQ(reply.call_id(), 9u);
  EXPECT_EQ(reply.status(), planet::DEADLINE_EXCEEDED);
  EXPECT_EQ(reply.message(), "no reply from robot1.navigation.moveTo within 250 ms");

  router.on_reply(*provider, reply_from_provider(server_id, "late"));
  EXPECT_EQ(caller->count(planet::Frame::kReply), 1u);
  EXPECT_EQ(router.pending(), 0u);
}

TEST_F(RouterTest, DeadlineComesFromCallThenServiceThenDefault) {
  ASSERT_TRUE(registry.register_service(provider, navigation_registration("robot1.slow", 5000)).ok());
  router.on_request(caller, request(1, "robot1.slow", "moveTo"));
  router.on_request(caller, request(2, "robot1.slow", "moveTo", 100));
  EXPECT_EQ(provider->frames()[0].request().deadline_ms(), 5000u);
  EXPECT_EQ(provider->frames()[1].request().deadline_ms(), 100u);
  timers.advance(std::chrono::milliseconds(100));
  ASSERT_EQ(caller->count(planet::Frame::kReply), 1u);
  EXPECT_EQ(caller->frames()[0].reply().call_id(), 2u);
  timers.advance(std::chrono::milliseconds(4900));
  ASSERT_EQ(caller->count(planet::Frame::kReply), 2u);
  EXPECT_EQ(caller->frames()[1].reply().message(), "no reply from robot1.slow.moveTo within 5000 ms");
}

TEST_F(RouterTest, ProviderGoneFailsItsPendingCalls) {
  router.on_request(caller, request(4, "robot1.navigation", "moveTo"));
  router.on_request(caller, request(5, "robot1.navigation", "setSpeed"));
  registry.remove_session(provider->id());
  router.on_session_closed(provider->id());
  ASSERT_EQ(caller->count(planet::Frame::kReply), 2u);
  for (const auto& frame : caller->frames()) {
    EXPECT_EQ(frame.reply().status(), planet::PROVIDER_GONE);
    EXPECT_EQ(frame.reply().message(), "provider sam@robot1 of robot1.navigation disconnected");
  }
  EXPECT_EQ(router.pending(), 0u);
  EXPECT_EQ(timers.pending(), 0u);
  router.on_request(caller, request(6, "robot1.navigation", "moveTo"));
  EXPECT_EQ(caller->frames().back().reply().status(), planet::UNKNOWN_SERVICE);
}

TEST_F(RouterTest, SendToAClosedProviderAnswersProviderGoneAtOnce) {
  provider->mark_closed();
  router.on_request(caller, request(4, "robot1.navigation", "moveTo"));
  auto reply = caller->wait_frame(planet::Frame::kReply);
  ASSERT_TRUE(reply);
  EXPECT_EQ(reply->reply().status(), planet::PROVIDER_GONE);
  EXPECT_EQ(router.pending(), 0u);
}

// Two providers of one service: replicas of one SAM (the same credential, sessions of their own).
class TwoProvidersTest : public RouterTest {
 protected:
  void SetUp() override {
    RouterTest::SetUp();
    ASSERT_TRUE(registry.register_service(replica_, navigation_registration("robot1.navigation")).ok());
  }
  // Who got each of the calls sent so far: "p" (provider) or "r" (replica), in call id order.
  std::string receivers() const {
    std::map<uint64_t, char> by_id;
    for (const auto& f : provider->frames()) by_id[f.request().call_id()] = 'p';
    for (const auto& f : replica_->frames()) by_id[f.request().call_id()] = 'r';
    std::string out;
    for (const auto& [id, who] : by_id) out += who;
    return out;
  }
  uint64_t last_call_id(const FakeSession& session) const { return session.frames().back().request().call_id(); }
  static RouterOptions roomy() {
    RouterOptions o = options();
    o.max_pending_calls = o.max_pending_calls_per_credential = o.max_pending_calls_per_session = 100;
    return o;
  }
  std::shared_ptr<FakeSession> replica_ = std::make_shared<FakeSession>(3, "sam@robot1", planet::SAM);
  Router routes_{roomy(), registry, builtins, timers};  // limits out of the way
};

TEST_F(TwoProvidersTest, ACallGoesToTheProviderWithFewestPendingAndOfEqualsToTheLeastRecentlyChosen) {
  for (uint64_t id = 1; id <= 4; ++id) routes_.on_request(caller, request(id, "robot1.navigation", "moveTo"));
  EXPECT_EQ(receivers(), "prpr");
  EXPECT_EQ(routes_.pending_at(provider->id()), 2u);
  EXPECT_EQ(routes_.pending_at(replica_->id()), 2u);
  // The provider answers one: it has the fewest pending, so it gets the next call, twice not.
  routes_.on_reply(*provider, reply_from_provider(provider->frames()[0].request().call_id(), "done"));
  routes_.on_request(caller, request(5, "robot1.navigation", "moveTo"));
  routes_.on_request(caller, request(6, "robot1.navigation", "moveTo"));
  EXPECT_EQ(receivers(), "prprpr");
  EXPECT_EQ(caller->count(planet::Frame::kReply), 1u);
}

TEST_F(TwoProvidersTest, AProviderLeavingFailsOnlyItsOwnCallsAndTheOtherServesTheNextOnes) {
  for (uint64_t id = 1; id <= 4; ++id) routes_.on_request(caller, request(id, "robot1.navigation", "moveTo"));
  ASSERT_EQ(receivers(), "prpr");
  registry.remove_session(provider->id());
  routes_.on_session_closed(provider->id());
  // Its two calls end PROVIDER_GONE (they may have run: they are not sent again); the replica's go on.
  ASSERT_EQ(caller->count(planet::Frame::kReply), 2u);
  for (const auto& frame : caller->frames()) {
    EXPECT_EQ(frame.reply().status(), planet::PROVIDER_GONE);
    EXPECT_EQ(frame.reply().message(), "provider sam@robot1 of robot1.navigation disconnected");
    EXPECT_TRUE(frame.reply().call_id() == 1 || frame.reply().call_id() == 3) << frame.reply().call_id();
  }
  EXPECT_EQ(replica_->count(planet::Frame::kRequest), 2u) << "nothing was sent again";
  EXPECT_EQ(routes_.pending(), 2u);
  routes_.on_request(caller, request(5, "robot1.navigation", "moveTo"));
  routes_.on_reply(*replica_, reply_from_provider(last_call_id(*replica_), "served"));
  auto last = caller->frames().back().reply();
  EXPECT_EQ(last.call_id(), 5u);
  EXPECT_EQ(last.status(), planet::OK);
  EXPECT_EQ(last.payload(), "served");
  EXPECT_EQ(provider->count(planet::Frame::kRequest), 2u);
}

TEST_F(TwoProvidersTest, ACallAClosedConnectionRefusedGoesToTheNextProvider) {
  // Closed, not yet removed: its connection refuses the frame, so nobody received the call.
  provider->mark_closed();
  routes_.on_request(caller, request(4, "robot1.navigation", "moveTo"));
  routes_.on_request(caller, request(5, "robot1.navigation", "moveTo", 0, /*oneway=*/true));
  EXPECT_EQ(provider->count(planet::Frame::kRequest), 0u);
  ASSERT_EQ(replica_->count(planet::Frame::kRequest), 2u);
  EXPECT_EQ(caller->count(planet::Frame::kReply), 0u);
  routes_.on_reply(*replica_, reply_from_provider(replica_->frames()[0].request().call_id(), "served"));
  ASSERT_EQ(caller->count(planet::Frame::kReply), 1u);
  EXPECT_EQ(caller->frames()[0].reply().status(), planet::OK);
  EXPECT_EQ(routes_.pending(), 0u);
  EXPECT_EQ(routes_.pending_at(replica_->id()), 0u);

  // Both refuse: PROVIDER_GONE at once.
  replica_->mark_closed();
  routes_.on_request(caller, request(6, "robot1.navigation", "moveTo"));
  ASSERT_EQ(caller->count(planet::Frame::kReply), 2u);
  EXPECT_EQ(caller->frames()[1].reply().status(), planet::PROVIDER_GONE);
  EXPECT_EQ(routes_.pending(), 0u);
}

TEST_F(TwoProvidersTest, AProviderSilentPastADeadlineIsPassedOverUntilItAnswersAgain) {
  routes_.on_request(caller, request(1, "robot1.navigation", "moveTo", 250));
  routes_.on_request(caller, request(2, "robot1.navigation", "moveTo", 250));
  ASSERT_EQ(receivers(), "pr");
  const uint64_t stuck = provider->frames()[0].request().call_id();
  routes_.on_reply(*replica_, reply_from_provider(last_call_id(*replica_), "ok"));
  timers.advance(std::chrono::milliseconds(250));  // the provider said nothing: paused, hung
  EXPECT_EQ(caller->frames().back().reply().status(), planet::DEADLINE_EXCEEDED);
  EXPECT_TRUE(routes_.suspected(provider->id()));
  EXPECT_FALSE(routes_.suspected(replica_->id()));
  // It has no call pending now, yet the next calls go to the replica, however many it holds.
  for (uint64_t id = 3; id <= 5; ++id) routes_.on_request(caller, request(id, "robot1.navigation", "moveTo"));
  EXPECT_EQ(receivers(), "prrrr");
  // Its late reply shows it runs again: it is chosen again.
  routes_.on_reply(*provider, reply_from_provider(stuck, "late"));
  EXPECT_FALSE(routes_.suspected(provider->id()));
  routes_.on_request(caller, request(6, "robot1.navigation", "moveTo"));
  EXPECT_EQ(receivers(), "prrrrp");
}

TEST_F(TwoProvidersTest, ASlowProviderThatAnswersOthersIsNotSuspected) {
  routes_.on_request(caller, request(1, "robot1.navigation", "moveTo", 250));
  routes_.on_request(caller, request(2, "robot1.navigation", "moveTo", 1000));
  routes_.on_request(caller, request(3, "robot1.navigation", "moveTo", 1000));
  ASSERT_EQ(receivers(), "prp");
  // The provider answers call 3 but not call 1: slow on one, not stuck.
  routes_.on_reply(*provider, reply_from_provider(last_call_id(*provider), "ok"));
  timers.advance(std::chrono::milliseconds(250));
  EXPECT_FALSE(routes_.suspected(provider->id()));
}

TEST_F(RouterTest, ASuspectedProviderAloneStillGetsTheCalls) {
  router.on_request(caller, request(1, "robot1.navigation", "moveTo", 100));
  timers.advance(std::chrono::milliseconds(100));
  ASSERT_TRUE(router.suspected(provider->id()));
  router.on_request(caller, request(2, "robot1.navigation", "moveTo", 100));
  EXPECT_EQ(provider->count(planet::Frame::kRequest), 2u);
}

TEST_F(RouterTest, CallerGoneDropsItsEntries) {
  router.on_request(caller, request(4, "robot1.navigation", "moveTo"));
  uint64_t server_id = provider->frames()[0].request().call_id();
  router.on_session_closed(caller->id());
  EXPECT_EQ(router.pending(), 0u);
  EXPECT_EQ(timers.pending(), 0u);
  router.on_reply(*provider, reply_from_provider(server_id, "nobody listens"));
  EXPECT_EQ(caller->count(planet::Frame::kReply), 0u);
}

TEST_F(RouterTest, UnknownServiceAndOperationAreNamed) {
  router.on_request(caller, request(1, "robot9.navigation", "moveTo"));
  router.on_request(caller, request(2, "robot1.navigation", "fly"));
  ASSERT_EQ(caller->count(planet::Frame::kReply), 2u);
  auto unknown = caller->frames()[0].reply();
  EXPECT_EQ(unknown.call_id(), 1u);
  EXPECT_EQ(unknown.status(), planet::UNKNOWN_SERVICE);
  EXPECT_EQ(unknown.message(), "no service named 'robot9.navigation' in space kr");
  auto no_op = caller->frames()[1].reply();
  EXPECT_EQ(no_op.status(), planet::UNKNOWN_OPERATION);
  EXPECT_EQ(no_op.message(), "interface test.Navigation has no operation 'fly'");
  EXPECT_EQ(provider->count(planet::Frame::kRequest), 0u);
}

TEST_F(RouterTest, OnewayIsForwardedWithoutBookkeeping) {
  router.on_request(caller, request(1, "robot1.navigation", "moveTo", 0, true));
  ASSERT_EQ(provider->count(planet::Frame::kRequest), 1u);
  EXPECT_TRUE(provider->frames()[0].request().oneway());
  EXPECT_EQ(router.pending(), 0u);
  EXPECT_EQ(timers.pending(), 0u);
  router.on_request(caller, request(2, "robot9.navigation", "moveTo", 0, true));  // unknown: logged, no reply
  EXPECT_EQ(caller->count(planet::Frame::kReply), 0u);
}

TEST_F(RouterTest, ReplyFromAnotherSessionIsIgnored) {
  router.on_request(caller, request(1, "robot1.navigation", "moveTo"));
  uint64_t server_id = provider->frames()[0].request().call_id();
  auto intruder = std::make_shared<FakeSession>(3, "intruder", planet::SAM);
  router.on_reply(*intruder, reply_from_provider(server_id, "forged"));
  EXPECT_EQ(caller->count(planet::Frame::kReply), 0u);
  router.on_reply(*provider, reply_from_provider(server_id, "real"));
  EXPECT_EQ(caller->frames()[0].reply().payload(), "real");
}

TEST_F(RouterTest, BuiltinRegistryIsServedLocally) {
  planet::Request list = request(11, "camus.registry", "List");
  list.set_payload(camus::ListRequest().SerializeAsString());
  router.on_request(caller, list);
  auto reply = caller->wait_frame(planet::Frame::kReply);
  ASSERT_TRUE(reply);
  EXPECT_EQ(reply->reply().call_id(), 11u);
  ASSERT_EQ(reply->reply().status(), planet::OK) << reply->reply().message();
  camus::ListReply services;
  ASSERT_TRUE(services.ParseFromString(reply->reply().payload()));
  EXPECT_EQ(services.services_size(), 2);
  router.on_request(caller, request(12, "camus.registry", "Fly"));
  EXPECT_EQ(caller->frames().back().reply().message(), "interface urs.camus.Registry has no operation 'Fly'");
}

TEST_F(RouterTest, InternalCallersGetCompletions) {
  std::optional<planet::CallResult> got;
  router.call(Caller{nullptr, "task:t/r1", planet::OPERATOR}, request(0, "robot1.navigation", "setSpeed"),
              [&got](planet::CallResult result) { got = std::move(result); });
  router.on_reply(*provider, reply_from_provider(provider->frames()[0].request().call_id(), "ok"));
  ASSERT_TRUE(got);
  EXPECT_EQ(got->payload, "ok");
}

TEST_F(RouterTest, DuplicateCallIdOfAPendingCallIsRefusedAndTheFirstGoesOn) {
  router.on_request(caller, request(7, "robot1.navigation", "moveTo"));
  router.on_request(caller, request(7, "robot1.navigation", "setSpeed"));
  ASSERT_EQ(provider->count(planet::Frame::kRequest), 1u);  // the second never reaches the provider
  ASSERT_EQ(caller->count(planet::Frame::kReply), 1u);
  auto refused = caller->frames()[0].reply();
  EXPECT_EQ(refused.call_id(), 7u);
  EXPECT_EQ(refused.status(), planet::BAD_ARGUMENTS);
  EXPECT_EQ(refused.message(),
            "call_id 7 is already pending on this connection (call ids must be unique among pending calls); the "
            "first call goes on");
  // A oneway reusing a pending id is dropped too.
  router.on_request(caller, request(7, "robot1.navigation", "setSpeed", 0, true));
  EXPECT_EQ(provider->count(planet::Frame::kRequest), 1u);
  // The first call is answered; then the id is free again.
  router.on_reply(*provider, reply_from_provider(provider->frames()[0].request().call_id(), "first"));
  EXPECT_EQ(caller->frames().back().reply().payload(), "first");
  router.on_request(caller, request(7, "robot1.navigation", "moveTo"));
  EXPECT_EQ(provider->count(planet::Frame::kRequest), 2u);
  // Another connection may use the same id at the same time.
  auto other = std::make_shared<FakeSession>(5, "cli2", planet::CLIENT);
  router.on_request(other, request(7, "robot1.navigation", "moveTo"));
  EXPECT_EQ(provider->count(planet::Frame::kRequest), 3u);
}

TEST_F(RouterTest, DeadlineAboveTheMaximumIsRefusedNotTruncated) {
  router.on_request(caller, request(1, "robot1.navigation", "moveTo", (uint64_t{1} << 32) + 5));
  router.on_request(caller, request(2, "robot1.navigation", "moveTo", 60001));
  router.on_request(caller, request(3, "robot1.navigation", "moveTo", 60000));
  ASSERT_EQ(caller->count(planet::Frame::kReply), 2u);
  EXPECT_EQ(caller->frames()[0].reply().status(), planet::BAD_ARGUMENTS);
  EXPECT_EQ(caller->frames()[0].reply().message(),
            "deadline_ms 4294967301 exceeds the server's limit of 60000 ms (max_deadline_ms)");
  EXPECT_EQ(caller->frames()[1].reply().call_id(), 2u);
  ASSERT_EQ(provider->count(planet::Frame::kRequest), 1u);
  EXPECT_EQ(provider->frames()[0].request().deadline_ms(), 60000u);
}

// Server-wide, a full pool refuses the credential over its fair share, not the next caller;
// the reserve (20% of 5) is kept for sam and operator sessions and the server's own calls.
TEST_F(RouterTest, PendingCallsAreBoundedPerSessionAndInFairSharesServerWide) {
  for (uint64_t id = 1; id <= 4; ++id) router.on_request(caller, request(id, "robot1.navigation", "moveTo"));
  EXPECT_EQ(router.pending(), 3u);
  ASSERT_EQ(caller->count(planet::Frame::kReply), 1u);
  EXPECT_EQ(caller->frames()[0].reply().call_id(), 4u);
  EXPECT_EQ(caller->frames()[0].reply().status(), planet::RESOURCE_EXHAUSTED);
  EXPECT_EQ(caller->frames()[0].reply().message(),
            "this connection already has 3 calls pending (max_pending_calls_per_session 3)");
  // The clients' pool (5 less 1 reserved) is full after one more call of another credential;
  // it still gets its fair share (2), and only then is refused.
  auto other = std::make_shared<FakeSession>(5, "cli2", planet::CLIENT);
  for (uint64_t id = 1; id <= 3; ++id) router.on_request(other, request(id, "robot1.navigation", "moveTo"));
  EXPECT_EQ(router.pending(), 5u);
  ASSERT_EQ(other->count(planet::Frame::kReply), 1u);
  EXPECT_EQ(other->frames()[0].reply().status(), planet::RESOURCE_EXHAUSTED);
  EXPECT_EQ(other->frames()[0].reply().message(),
            "the server holds 5 calls pending for client credentials, its limit (max_pending_calls 5 less the 1 kept "
            "for sam and operator sessions, reserved_percent 20); credential 'cli2' holds 2, over its fair share of "
            "2; retry later");
  // A sam session (and the server itself) call on.
  auto sam = std::make_shared<FakeSession>(6, "sam@robot2", planet::SAM);
  router.on_request(sam, request(1, "robot1.navigation", "moveTo"));
  EXPECT_EQ(sam->count(planet::Frame::kReply), 0u);
  bool completed = false;
  router.call(Caller{nullptr, "task:t/r1", planet::OPERATOR}, request(0, "camus.registry", "List"),
              [&](planet::CallResult r) { completed = r.status != planet::RESOURCE_EXHAUSTED; });
  EXPECT_TRUE(completed);
  // Oneways hold nothing and are not counted.
  router.on_request(caller, request(9, "robot1.navigation", "setSpeed", 0, true));
  EXPECT_EQ(provider->count(planet::Frame::kRequest), 7u);
  // Answered calls free their places.
  EXPECT_EQ(router.pending(), 6u);
  router.on_reply(*provider, reply_from_provider(provider->frames()[0].request().call_id(), "done"));
  EXPECT_EQ(router.pending(), 5u);
}

// One credential on many connections: max_pending_calls_per_credential counts them together.
TEST_F(RouterTest, PendingCallsAreBoundedPerCredentialAcrossItsConnections) {
  RouterOptions o = options();
  o.max_pending_calls = 100;
  o.max_pending_calls_per_credential = 4;
  Router bounded(o, registry, builtins, timers);
  std::vector<std::shared_ptr<FakeSession>> connections;
  for (uint64_t i = 0; i < 3; ++i) {
    connections.push_back(std::make_shared<FakeSession>(10 + i, "mallory", planet::CLIENT));
    for (uint64_t id = 1; id <= 2; ++id)
      bounded.on_request(connections.back(), request(id, "robot1.navigation", "moveTo"));
  }
  EXPECT_EQ(bounded.pending(), 4u);
  ASSERT_EQ(connections[2]->count(planet::Frame::kReply), 2u);
  EXPECT_EQ(connections[2]->frames()[0].reply().message(),
            "credential 'mallory' holds 4 calls pending (max_pending_calls_per_credential 4)");
  bounded.on_request(caller, request(1, "robot1.navigation", "moveTo"));
  EXPECT_EQ(caller->count(planet::Frame::kReply), 0u);
  EXPECT_EQ(bounded.pending(), 5u);
  // A closed connection gives its calls back to the credential.
  bounded.on_session_closed(connections[0]->id());
  bounded.on_request(connections[2], request(3, "robot1.navigation", "moveTo"));
  EXPECT_EQ(bounded.pending(), 4u);
  EXPECT_EQ(connections[2]->count(planet::Frame::kReply), 2u);
}

TEST_F(RouterTest, BuiltinOperationsNeedTheirRole) {
  planet::Request define = request(1, "camus.registry", "Register");
  define.set_payload(navigation_registration("cli.nav").SerializeAsString());
  router.on_request(caller, define);
  auto reply = caller->wait_frame(planet::Frame::kReply);
  ASSERT_TRUE(reply);
  EXPECT_EQ(reply->reply().status(), planet::PERMISSION_DENIED);
  EXPECT_EQ(reply->reply().message(), "camus.registry.Register needs role sam; credential 'cli@host' has role client");
  EXPECT_FALSE(registry.route("cli.nav").has_value());
}

TEST_F(RouterTest, ShutdownAnswersPendingAndLaterCallsUnavailable) {
  router.on_request(caller, request(1, "robot1.navigation", "moveTo"));
  router.shutdown();
  ASSERT_EQ(caller->count(planet::Frame::kReply), 1u);
  EXPECT_EQ(caller->frames()[0].reply().status(), planet::UNAVAILABLE);
  EXPECT_EQ(caller->frames()[0].reply().message(), "server is shutting down; no reply from robot1.navigation.moveTo");
  router.on_request(caller, request(2, "robot1.navigation", "moveTo"));
  EXPECT_EQ(caller->frames()[1].reply().message(), "server is shutting down; robot1.navigation.moveTo not called");
}

// A call answered long before its deadline leaves nothing in the timer thread: 10,000 calls with
// 24 h deadlines, each answered, hold no timer.
TEST(TimerThread, ACancelledTimerIsForgottenAtOnce) {
  TimerThread timers;
  std::vector<Scheduler::TimerId> ids;
  for (int i = 0; i < 10000; ++i) ids.push_back(timers.schedule_after(std::chrono::hours(24), [] {}));
  EXPECT_EQ(timers.pending(), 10000u);
  for (auto id : ids) EXPECT_TRUE(timers.cancel(id));
  EXPECT_EQ(timers.pending(), 0u);
  EXPECT_FALSE(timers.cancel(ids.front()));
  // The thread still runs what is due.
  std::mutex mutex;
  std::condition_variable ran;
  bool done = false;
  timers.schedule_after(std::chrono::milliseconds(1), [&] {
    std::lock_guard<std::mutex> lock(mutex);
    done = true;
    ran.notify_all();
  });
  std::unique_lock<std::mutex> lock(mutex);
  EXPECT_TRUE(ran.wait_for(lock, std::chrono::seconds(10), [&] { return done; }));
}

}  // namespace
}  // namespace urs::camus_server::test
