#include "urs/camus_server/session_handler.hpp"

#include <gtest/gtest.h>

#include "fakes.hpp"

namespace urs::camus_server::test {
namespace {

// The handler wired to real components (in memory), as in the server.
class HandlerTest : public ::testing::Test, protected ServerCore {
 protected:
  void SetUp() override {
    const auto* file = camus::ServiceInfo::descriptor()->file();
    registry.add_builtin("camus.registry", *file->FindServiceByName("Registry"));
    registry.add_builtin("camus.context", *file->FindServiceByName("Context"));
    container.add("camus.context", context_agent);
  }

  // Hands the handler `session`'s Subscribe of `pattern` under `subscription_id`.
  void subscribe(const std::shared_ptr<FakeSession>& session, uint64_t subscription_id, const std::string& pattern) {
    planet::Frame frame;
    frame.mutable_subscribe()->set_subscription_id(subscription_id);
    frame.mutable_subscribe()->set_pattern(pattern);
    handler.on_frame(session, std::move(frame));
  }

  // A Publish of `topic` under `publish_id`, carrying `payload`.
  static planet::Frame publish_frame(uint64_t publish_id, const std::string& topic, const std::string& payload = "") {
    planet::Frame frame;
    frame.mutable_publish()->set_publish_id(publish_id);
    frame.mutable_publish()->set_topic(topic);
    frame.mutable_publish()->set_payload(payload);
    return frame;
  }

  planet::Frame request(uint64_t call_id, const std::string& service, const std::string& op,
                        const google::protobuf::Message& payload) {
    planet::Frame frame;
    auto* r = frame.mutable_request();
    r->set_call_id(call_id);
    r->set_service(service);
    r->set_operation(op);
    r->set_payload(payload.SerializeAsString());
    return frame;
  }

  ContextAgent context_agent{context};
  InlineContainer container{bus_sink};
  RegistryService registry_service{registry};
  BuiltinServices builtins{registry_service, container};
  Router router{RouterOptions{"kr", std::chrono::milliseconds(1000)}, registry, builtins, timers};
  CamusSessionHandler handler{registry, router, bus};
  std::shared_ptr<FakeSession> client = std::make_shared<FakeSession>(1, "cli@host", planet::CLIENT);
  std::shared_ptr<FakeSession> sam = std::make_shared<FakeSession>(2, "sam@robot1", planet::SAM);
  std::shared_ptr<FakeSession> ops = std::make_shared<FakeSession>(3, "ops", planet::OPERATOR);
};

TEST_F(HandlerTest, ContextSetAndGetThroughFrames) {
  handler.on_open(client);
  camus::ContextSetRequest set;
  set.set_key("robot1/battery");
  set.mutable_value()->set_number_value(0.5);
  set.set_source("declared");
  handler.on_frame(client, request(1, "camus.context", "Set", set));  // a client may not set context
  handler.on_frame(ops, request(1, "camus.context", "Set", set));
  ASSERT_TRUE(ops->wait_frame(planet::Frame::kReply, 0));
  camus::ContextGetRequest get;
  get.set_key("robot1/battery");
  handler.on_frame(client, request(2, "camus.context", "Get", get));
  auto first = client->wait_frame(planet::Frame::kReply, 0);
  auto second = client->wait_frame(planet::Frame::kReply, 1);
  ASSERT_TRUE(first && second);
  EXPECT_EQ(first->reply().status(), planet::PERMISSION_DENIED);
  EXPECT_EQ(first->reply().message(), "camus.context.Set needs role operator; credential 'cli@host' has role client");
  ASSERT_EQ(second->reply().status(), planet::OK) << second->reply().message();
  camus::ContextEntry entry;
  ASSERT_TRUE(entry.ParseFromString(second->reply().payload()));
  EXPECT_EQ(entry.source(), "ops");
  EXPECT_EQ(entry.origin(), "declared");
  EXPECT_DOUBLE_EQ(entry.value().number_value(), 0.5);
}

TEST_F(HandlerTest, PublishSubscribeAndUnsubscribeThroughFrames) {
  subscribe(client, 4, "kr/robot1/#");
  planet::Frame publish = publish_frame(1, "kr/robot1/arrived", "here");
  handler.on_frame(sam, planet::Frame(publish));
  handler.on_frame(sam, planet::Frame(publish));  // resent: deduplicated
  auto ack = client->wait_frame(planet::Frame::kSubscribeAck);
  ASSERT_TRUE(ack);
  EXPECT_EQ(ack->subscribe_ack().status(), planet::OK);
  auto event = client->wait_frame(planet::Frame::kEvent);
  ASSERT_TRUE(event);
  EXPECT_EQ(event->event().subscription_id(), 4u);
  EXPECT_EQ(event->event().source(), "sam@robot1");
  EXPECT_EQ(event->event().payload(), "here");
  auto ack1 = sam->wait_frame(planet::Frame::kPublishAck, 0);
  auto ack2 = sam->wait_frame(planet::Frame::kPublishAck, 1);
  ASSERT_TRUE(ack1 && ack2);
  EXPECT_EQ(ack1->publish_ack().seq(), ack2->publish_ack().seq());

  planet::Frame unsubscribe;
  unsubscribe.mutable_unsubscribe()->set_subscription_id(4);
  handler.on_frame(client, std::move(unsubscribe));
  publish.mutable_publish()->set_publish_id(2);
  handler.on_frame(sam, std::move(publish));
  bus.flush();
  EXPECT_EQ(client->count(planet::Frame::kEvent), 1u);
}

TEST_F(HandlerTest, EventsCarryTheAuthenticatedIdentityAndServerTopicsAreRefused) {
  subscribe(client, 1, "#");
  ASSERT_TRUE(client->wait_frame(planet::Frame::kSubscribeAck));
  // A session whose peer_name claims to be the server: its identity is what was authenticated.
  auto impostor = std::make_shared<FakeSession>(7, "intruder", planet::OPERATOR);
  handler.on_frame(impostor, publish_frame(1, "registry/diag"));
  auto refused = impostor->wait_frame(planet::Frame::kPublishAck);
  ASSERT_TRUE(refused);
  EXPECT_EQ(refused->publish_ack().status(), planet::PERMISSION_DENIED);
  handler.on_frame(impostor, publish_frame(2, "kr/news"));
  auto event = client->wait_frame(planet::Frame::kEvent);
  ASSERT_TRUE(event);
  EXPECT_EQ(event->event().topic(), "kr/news");
  EXPECT_EQ(event->event().source(), "intruder");
}

TEST_F(HandlerTest, AnotherSessionsPublishIdsDoNotPoisonDeduplication) {
  subscribe(client, 1, "kr/#");
  ASSERT_TRUE(client->wait_frame(planet::Frame::kSubscribeAck));
  // Same name, same role, another session: its ids are its own.
  auto stranger = std::make_shared<FakeSession>(8, "sam@robot1", planet::SAM);
  for (uint64_t id = 1; id <= 3; ++id) handler.on_frame(stranger, publish_frame(id, "kr/junk"));
  handler.on_frame(sam, publish_frame(1, "kr/robot1/arrived"));
  auto ack = sam->wait_frame(planet::Frame::kPublishAck);
  ASSERT_TRUE(ack);
  EXPECT_EQ(ack->publish_ack().seq(), 4u);
  auto event = client->wait_frame(planet::Frame::kEvent, 3);
  ASSERT_TRUE(event);
  EXPECT_EQ(event->event().topic(), "kr/robot1/arrived");
}

TEST_F(HandlerTest, CloseRemovesRegistrationsAndFailsCalls) {
  handler.on_frame(sam, request(1, "camus.registry", "Register", navigation_registration("robot1.navigation")));
  auto registered = sam->wait_frame(planet::Frame::kReply);
  ASSERT_EQ(registered->reply().status(), planet::OK) << registered->reply().message();
  handler.on_frame(client, request(5, "robot1.navigation", "getPosition", camus::ListRequest()));
  ASSERT_TRUE(sam->wait_frame(planet::Frame::kRequest));
  handler.on_close(sam, "heartbeat timeout");
  auto reply = client->wait_frame(planet::Frame::kReply);
  ASSERT_TRUE(reply);
  EXPECT_EQ(reply->reply().call_id(), 5u);
  EXPECT_EQ(reply->reply().status(), planet::PROVIDER_GONE);
  EXPECT_TRUE(registry.list("robot1.*").empty());
}

TEST_F(HandlerTest, UnexpectedFrameClosesOnlyThatSession) {
  planet::Frame welcome;
  welcome.mutable_welcome()->set_version(1);
  handler.on_frame(client, std::move(welcome));
  EXPECT_TRUE(client->closed());
  EXPECT_EQ(client->close_reason(), "unexpected 'welcome' frame: a server does not accept it");
  EXPECT_FALSE(sam->closed());
}

}  // namespace
}  // namespace urs::camus_server::test
