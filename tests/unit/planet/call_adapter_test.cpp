// The Planet edge of the call model: statuses, replies, requests and responders converted both ways.

#include "urs/planet/call_adapter.hpp"

#include <gtest/gtest.h>

#include <optional>

namespace urs::planet {
namespace {

TEST(PlanetCallAdapter, EveryPlanetStatusHasTheCallStatusOfItsNumber) {
  const auto* descriptor = Status_descriptor();
  for (int i = 0; i < descriptor->value_count(); ++i) {
    const auto wire = static_cast<Status>(descriptor->value(i)->number());
    const call::Status neutral = to_call(wire);
    EXPECT_EQ(call::status_number(neutral), descriptor->value(i)->number());
    EXPECT_EQ(call::status_name(neutral), descriptor->value(i)->name());
    EXPECT_EQ(to_planet(neutral), wire);
  }
}

TEST(PlanetCallAdapter, AStatusOfANewerPeerIsInternal) {
  EXPECT_EQ(to_call(static_cast<Status>(99)), call::Status::INTERNAL);
}

TEST(PlanetCallAdapter, RepliesKeepEveryField) {
  const auto reply = to_reply(CallResult::user_exception("urs.X", "bytes", "boom"));
  EXPECT_EQ(reply.status, call::Status::USER_EXCEPTION);
  EXPECT_EQ(reply.exception_type, "urs.X");
  EXPECT_EQ(reply.payload, "bytes");
  EXPECT_EQ(reply.message, "boom");
  const auto back = to_call_result(call::Reply::error(call::Status::NOT_FOUND, "no key"));
  EXPECT_EQ(back.status, NOT_FOUND);
  EXPECT_EQ(back.message, "no key");
}

TEST(PlanetCallAdapter, RequestsCarryTheDeadlineFromTheirArrival) {
  Request wire;
  wire.set_service("robot1.diag");
  wire.set_operation("echo");
  wire.set_payload("p");
  wire.set_deadline_ms(250);
  const auto received = std::chrono::steady_clock::now();
  const auto request = to_call_request(wire, caller_identity("lab", "sam-robot1", SAM), received);
  EXPECT_EQ(request.service, "robot1.diag");
  EXPECT_EQ(request.operation, "echo");
  EXPECT_EQ(request.payload, "p");
  EXPECT_EQ(request.deadline, received + std::chrono::milliseconds(250));
  EXPECT_FALSE(request.oneway);
  EXPECT_EQ(request.caller.space, "lab");
  EXPECT_EQ(request.caller.name, "sam-robot1");
  EXPECT_EQ(request.caller.role, "sam");

  wire.set_deadline_ms(0);
  wire.set_oneway(true);
  const auto unbounded = to_call_request(wire, {}, received);
  EXPECT_FALSE(unbounded.has_deadline());
  EXPECT_TRUE(unbounded.oneway);
  EXPECT_FALSE(unbounded.caller.known());

  wire.set_deadline_ms(UINT64_MAX);
  EXPECT_FALSE(to_call_request(wire, {}, received).has_deadline());
}

TEST(PlanetCallAdapter, TheCallerIsTheOneTheServerNamed) {
  Request wire;
  EXPECT_FALSE(routed_caller(wire, "kr").known());  // the server named none
  wire.mutable_caller()->set_name("operator-ann");
  wire.mutable_caller()->set_role(CLIENT);
  const call::Identity caller = routed_caller(wire, "kr");
  EXPECT_EQ(caller.space, "kr");
  EXPECT_EQ(caller.name, "operator-ann");
  EXPECT_EQ(caller.role, "client");
}

TEST(PlanetCallAdapter, ResponderAnswersThePlanetResponder) {
  std::optional<CallResult> result;
  call::Responder responder = to_call_responder(Responder::from_callback([&](CallResult r) { result = r; }));
  EXPECT_TRUE(responder.pending());
  responder.reply(call::Reply::success("p"));
  ASSERT_TRUE(result);
  EXPECT_EQ(result->status, OK);
  EXPECT_EQ(result->payload, "p");
}

TEST(PlanetCallAdapter, ResponderDroppedUnansweredAnswersInternal) {
  std::optional<CallResult> result;
  {
    call::Responder responder = to_call_responder([&](CallResult r) { result = r; });
  }
  ASSERT_TRUE(result);
  EXPECT_EQ(result->status, INTERNAL);
}

TEST(PlanetCallAdapter, AOnewayResponderAnswersNowhere) { EXPECT_FALSE(to_call_responder(Responder()).pending()); }

}  // namespace
}  // namespace urs::planet
