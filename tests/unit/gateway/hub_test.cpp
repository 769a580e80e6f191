// The hub against in-memory outboxes: what each client is sent, and only that.
#include "urs/gateway/hub.hpp"

#include <google/protobuf/struct.pb.h>
#include <google/protobuf/util/json_util.h>
#include <gtest/gtest.h>

#include <mutex>
#include <tuple>

namespace fg = urs::gateway::foxglove;
namespace gp = google::protobuf;
using urs::gateway::Caller;
using urs::gateway::CallReply;
using urs::gateway::Hub;
using urs::gateway::Latch;
using urs::gateway::Role;

namespace {

struct Frame {
  bool text = false;
  std::string bytes;
};

class RecordingOutbox : public urs::gateway::Outbox {
 public:
  bool send_text(std::string text) override {
    std::lock_guard lock(mutex);
    frames.push_back({true, std::move(text)});
    return true;
  }
  bool send_binary(std::string header, std::shared_ptr<const std::string> payload) override {
    std::lock_guard lock(mutex);
    frames.push_back({false, header + (payload ? *payload : std::string())});
    return true;
  }
  // The JSON messages with this op.
  std::vector<gp::Struct> json(const std::string& op) {
    std::lock_guard lock(mutex);
    std::vector<gp::Struct> out;
    for (const auto& frame : frames) {
      if (!frame.text) continue;
      gp::Value value;
      if (gp::util::JsonStringToMessage(frame.bytes, &value).ok() &&
          value.struct_value().fields().at("op").string_value() == op) {
        out.push_back(value.struct_value());
      }
    }
    return out;
  }
  // Message data frames: (subscription id, payload).
  std::vector<std::pair<uint32_t, std::string>> data() {
    std::lock_guard lock(mutex);
    std::vector<std::pair<uint32_t, std::string>> out;
    for (const auto& frame : frames) {
      if (frame.text || frame.bytes.empty() || frame.bytes[0] != 0x01) continue;
      uint32_t id = 0;
      for (int i = 3; i >= 0; --i) id = (id << 8) | static_cast<uint8_t>(frame.bytes[1 + i]);
      out.emplace_back(id, frame.bytes.substr(13));
    }
    return out;
  }
  std::vector<std::string> statuses() {
    std::vector<std::string> out;
    for (const auto& status : json("status")) out.push_back(status.fields().at("message").string_value());
    return out;
  }
  void clear() {
    std::lock_guard lock(mutex);
    frames.clear();
  }
  std::mutex mutex;
  std::vector<Frame> frames;
};

std::string service_call(uint32_t service, uint32_t call, const std::string& encoding, const std::string& payload) {
  std::string out(1, '\x02');
  for (uint32_t v : {service, call, static_cast<uint32_t>(encoding.size())}) {
    for (int i = 0; i < 4; ++i) out += static_cast<char>((v >> (8 * i)) & 0xff);
  }
  return out + encoding + payload;
}

auto payload(const std::string& text) { return std::make_shared<const std::string>(text); }

class HubTest : public ::testing::Test {
 protected:
  Hub hub{urs::gateway::HubOptions{"test", {{"space", "lab"}}, "session-1", 2, 16, 2}};
  std::shared_ptr<RecordingOutbox> a = std::make_shared<RecordingOutbox>();
  std::shared_ptr<RecordingOutbox> b = std::make_shared<RecordingOutbox>();
};

}  // namespace

TEST_F(HubTest, ConnectSendsServerInfoChannelsAndServices) {
  const uint32_t poses = hub.add_channel({"/poses", "urs.gateway.Pose", "{}", Latch::keyed, 0});
  hub.add_service({0, "diag/echo", "URS.Diagnostic.echo", {}, {}}, nullptr);
  hub.connect(a, Role::viewer, "");
  auto info = a->json("serverInfo");
  ASSERT_EQ(info.size(), 1u);
  EXPECT_EQ(info[0].fields().at("sessionId").string_value(), "session-1");
  EXPECT_EQ(info[0].fields().at("metadata").struct_value().fields().at("role").string_value(), "viewer");
  auto channels = a->json("advertise");
  ASSERT_EQ(channels.size(), 1u);
  EXPECT_EQ(channels[0].fields().at("channels").list_value().values(0).struct_value().fields().at("id").number_value(),
            poses);
  EXPECT_EQ(a->json("advertiseServices").size(), 1u);
  ASSERT_FALSE(a->frames.empty());
  EXPECT_TRUE(a->frames.front().bytes.find("serverInfo") != std::string::npos) << "serverInfo comes first";
}

TEST_F(HubTest, OnlySubscribersGetMessagesAndLatchedOnesComeFirst) {
  const uint32_t poses = hub.add_channel({"/poses", "P", "{}", Latch::keyed, 0});
  const uint32_t events = hub.add_channel({"/events", "E", "{}", Latch::history, 2});
  hub.publish(poses, payload("robot1@0"), 1, "robot1");
  hub.publish(poses, payload("robot1@1"), 2, "robot1");
  hub.publish(poses, payload("robot2@0"), 3, "robot2");
  for (int i = 0; i < 3; ++i) hub.publish(events, payload("e" + std::to_string(i)), 4);
  const uint64_t ca = hub.connect(a, Role::viewer, "");
  hub.connect(b, Role::viewer, "");
  hub.receive_text(ca, R"({"op":"subscribe","subscriptions":[{"id":7,"channelId":)" + std::to_string(poses) +
                           R"(},{"id":8,"channelId":)" + std::to_string(events) + "}]}");
  EXPECT_EQ(a->data(),
            (std::vector<std::pair<uint32_t, std::string>>{{7, "robot1@1"}, {7, "robot2@0"}, {8, "e1"}, {8, "e2"}}));
  hub.publish(poses, payload("robot1@2"), 5, "robot1");
  EXPECT_EQ(a->data().back(), (std::pair<uint32_t, std::string>{7, "robot1@2"}));
  EXPECT_TRUE(b->data().empty()) << "b subscribed to nothing";
  hub.receive_text(ca, R"({"op":"unsubscribe","subscriptionIds":[7]})");
  a->clear();
  hub.publish(poses, payload("robot1@3"), 6, "robot1");
  EXPECT_TRUE(a->data().empty());
  EXPECT_EQ(hub.subscribers(poses), 0u);
  // A removed key is not replayed to later subscribers.
  hub.publish(poses, payload("robot2 gone"), 7, "robot2", true);
  const uint64_t cb = hub.connect(b, Role::viewer, "");
  b->clear();
  hub.receive_text(cb, R"({"op":"subscribe","subscriptions":[{"id":1,"channelId":)" + std::to_string(poses) + "}]}");
  EXPECT_EQ(b->data(), (std::vector<std::pair<uint32_t, std::string>>{{1, "robot1@3"}}));
}

TEST_F(HubTest, BadInputGetsAStatusAndChangesNothing) {
  const uint32_t poses = hub.add_channel({"/poses", "P", "{}", Latch::none, 0});
  const uint64_t ca = hub.connect(a, Role::viewer, "");
  const uint64_t cb = hub.connect(b, Role::viewer, "");
  hub.receive_text(cb, R"({"op":"subscribe","subscriptions":[{"id":1,"channelId":)" + std::to_string(poses) + "}]}");
  hub.receive_text(ca, "{oops");
  hub.receive_text(ca, R"({"op":"launch"})");
  hub.receive_text(ca, R"({"op":"subscribe","subscriptions":[{"id":1,"channelId":999}]})");
  hub.receive_text(ca, R"({"op":"subscribe","subscriptions":[{"id":1,"channelId":)" + std::to_string(poses) + "}]}");
  hub.receive_text(ca, R"({"op":"subscribe","subscriptions":[{"id":1,"channelId":)" + std::to_string(poses) + "}]}");
  hub.receive_text(ca, R"({"op":"unsubscribe","subscriptionIds":[5]})");
  hub.receive_text(ca, R"({"op":"getParameters","parameterNames":[]})");
  hub.receive_binary(ca, std::string("\x07", 1));
  const auto statuses = a->statuses();
  ASSERT_EQ(statuses.size(), 7u);
  EXPECT_EQ(statuses[0].rfind("not JSON", 0), 0u);
  EXPECT_EQ(statuses[1], "unknown op 'launch'");
  EXPECT_EQ(statuses[2], "subscribe: unknown channel 999");
  EXPECT_EQ(statuses[3], "subscribe: subscription id 1 is in use (unsubscribe it first)");
  EXPECT_EQ(statuses[4], "unsubscribe: no subscription 5");
  EXPECT_EQ(statuses[5].rfind("'getParameters' is not supported", 0), 0u);
  EXPECT_EQ(statuses[6], "unknown binary opcode 7");
  EXPECT_EQ(a->json("status")[0].fields().at("level").number_value(), 2);
  hub.publish(poses, payload("p"), 1);
  EXPECT_EQ(a->data().size(), 1u) << "a's one valid subscription still works";
  EXPECT_EQ(b->data().size(), 1u) << "b is not affected";
  EXPECT_TRUE(b->statuses().empty());
}

TEST_F(HubTest, ServiceCallsNeedAnOperatorAndAreAnswered) {
  std::vector<std::string> got;
  std::vector<std::function<void(CallReply)>> pending;
  const uint32_t echo =
      hub.add_service({0, "diag/echo", "URS.Diagnostic.echo", {}, {}},
                      [&](const Caller& caller, std::string json, std::function<void(CallReply)> reply) {
                        got.push_back(caller.login + " " + json);
                        pending.push_back(std::move(reply));
                      });
  const uint64_t viewer = hub.connect(a, Role::viewer, "");
  const uint64_t op = hub.connect(b, Role::operator_, "login-1");
  hub.receive_binary(viewer, service_call(echo, 1, "json", R"({"text":"hi"})"));
  ASSERT_EQ(a->json("serviceCallFailure").size(), 1u);
  EXPECT_EQ(a->json("serviceCallFailure")[0].fields().at("message").string_value().rfind("PERMISSION_DENIED: ", 0), 0u);
  EXPECT_TRUE(got.empty());

  hub.receive_binary(op, service_call(echo, 1, "json", R"({"text":"hi"})"));
  hub.receive_binary(op, service_call(echo, 2, "cbor", "x"));
  hub.receive_binary(op, service_call(99, 3, "json", "{}"));
  hub.receive_binary(op, service_call(echo, 4, "json", "{}"));
  hub.receive_binary(op, service_call(echo, 5, "json", "{}"));  // a third in flight: over the limit of 2
  EXPECT_EQ(got, (std::vector<std::string>{R"(login-1 {"text":"hi"})", "login-1 {}"}));
  const auto failures = b->json("serviceCallFailure");
  ASSERT_EQ(failures.size(), 3u);
  EXPECT_EQ(failures[0].fields().at("message").string_value(),
            "encoding 'cbor' is not supported (supportedEncodings: json)");
  EXPECT_EQ(failures[1].fields().at("message").string_value(), "unknown service id 99");
  EXPECT_EQ(failures[2].fields().at("callId").number_value(), 5);
  pending[0](CallReply::success(R"({"result":"hi"})"));
  pending[1](CallReply::failure("USER_EXCEPTION URS.Failure {}"));
  bool answered = false;
  for (const auto& frame : b->frames) {
    if (!frame.text && frame.bytes[0] == 0x03) {
      EXPECT_EQ(frame.bytes, std::string("\x03", 1) +
                                 std::string({static_cast<char>(echo), 0, 0, 0, 1, 0, 0, 0, 4, 0, 0, 0}) + "json" +
                                 R"({"result":"hi"})");
      answered = true;
    }
  }
  EXPECT_TRUE(answered);
  EXPECT_EQ(b->json("serviceCallFailure").back().fields().at("message").string_value(),
            "USER_EXCEPTION URS.Failure {}");
  // A reply to a client that left goes nowhere.
  hub.receive_binary(op, service_call(echo, 6, "json", "{}"));
  hub.disconnect(op);
  pending.back()(CallReply::success("{}"));
}

TEST_F(HubTest, ChannelsAndServicesComeAndGo) {
  const uint64_t ca = hub.connect(a, Role::viewer, "");
  const uint32_t robot = hub.add_channel({"/lab/robot1/pose", "P", "{}", Latch::keyed, 0});
  hub.receive_text(ca, R"({"op":"subscribe","subscriptions":[{"id":3,"channelId":)" + std::to_string(robot) + "}]}");
  hub.remove_channel(robot);
  EXPECT_EQ(a->json("unadvertise").size(), 1u);
  hub.publish(robot, payload("late"), 1);
  EXPECT_TRUE(a->data().empty());
  // Its subscription id is free again.
  const uint32_t again = hub.add_channel({"/lab/robot1/pose", "P", "{}", Latch::keyed, 0});
  EXPECT_NE(again, robot);
  hub.receive_text(ca, R"({"op":"subscribe","subscriptions":[{"id":3,"channelId":)" + std::to_string(again) + "}]}");
  EXPECT_TRUE(a->statuses().empty());
  const uint32_t service = hub.add_service({0, "x/y", "T", {}, {}}, nullptr);
  hub.remove_service(service);
  EXPECT_EQ(a->json("advertiseServices").size(), 1u);
  EXPECT_EQ(a->json("unadvertiseServices").size(), 1u);
}

TEST_F(HubTest, ConnectionGraphGoesToItsSubscribersAsChanges) {
  fg::GraphUpdate graph;
  graph.advertised_services = {{"jp/robot1.navigation", {"jp:bridge-jp"}}, {"kr/diag", {"kr:sam"}}};
  graph.published_topics = {{"/poses", {"space:jp"}}};
  hub.set_graph(graph);
  const uint64_t ca = hub.connect(a, Role::viewer, "");
  hub.connect(b, Role::viewer, "");
  hub.receive_text(ca, R"({"op":"subscribeConnectionGraph"})");
  auto first = a->json("connectionGraphUpdate");
  ASSERT_EQ(first.size(), 1u);
  EXPECT_EQ(first[0].fields().at("advertisedServices").list_value().values_size(), 2);
  graph.advertised_services.pop_back();
  graph.published_topics[0].ids.push_back("space:kr");
  hub.set_graph(graph);
  auto updates = a->json("connectionGraphUpdate");
  ASSERT_EQ(updates.size(), 2u);
  EXPECT_EQ(updates[1].fields().at("removedServices").list_value().values(0).string_value(), "kr/diag");
  EXPECT_EQ(updates[1].fields().at("advertisedServices").list_value().values_size(), 0);
  EXPECT_EQ(updates[1]
                .fields()
                .at("publishedTopics")
                .list_value()
                .values(0)
                .struct_value()
                .fields()
                .at("publisherIds")
                .list_value()
                .values_size(),
            2);
  EXPECT_TRUE(b->json("connectionGraphUpdate").empty()) << "b did not subscribe to the graph";
  hub.receive_text(ca, R"({"op":"unsubscribeConnectionGraph"})");
  graph.published_topics.clear();
  hub.set_graph(graph);
  EXPECT_EQ(a->json("connectionGraphUpdate").size(), 2u);
}

TEST_F(HubTest, KeyedChannelsKeepBoundedKeys) {
  const uint32_t context = hub.add_channel({"/context", "C", "{}", Latch::keyed, 0});
  for (int i = 0; i < 5; ++i) hub.publish(context, payload("k" + std::to_string(i)), 1, "k" + std::to_string(i));
  const uint64_t ca = hub.connect(a, Role::viewer, "");
  hub.receive_text(ca, R"({"op":"subscribe","subscriptions":[{"id":1,"channelId":)" + std::to_string(context) + "}]}");
  EXPECT_EQ(a->data().size(), 2u) << "max_keys_per_channel is 2 here";
}

TEST(HubPublish, OnlyOfferedWhenPlayingAndOnlyToOperators) {
  Hub live{urs::gateway::HubOptions{}};
  auto client = std::make_shared<RecordingOutbox>();
  const uint64_t id = live.connect(client, Role::operator_, "");
  live.receive_text(id,
                    R"({"op":"advertise","channels":[{"id":1,"topic":"/poses","encoding":"json","schemaName":"P"}]})");
  ASSERT_EQ(client->statuses().size(), 1u);
  EXPECT_EQ(client->statuses()[0].rfind("'advertise' is not supported by this server", 0), 0u) << client->statuses()[0];

  urs::gateway::HubOptions options;
  options.client_publish = true;
  options.max_client_channels = 2;
  Hub playing{options};
  std::vector<std::tuple<std::string, std::string, std::string>> taken;
  playing.set_publish_handler([&taken](const urs::gateway::Caller& caller, const std::string& topic,
                                       const std::string& schema, const std::string& data) -> std::string {
    EXPECT_EQ(caller.role, Role::operator_);
    if (topic == "/nowhere") return "not a topic of the gateway";
    taken.emplace_back(topic, schema, data);
    return {};
  });
  auto viewer = std::make_shared<RecordingOutbox>();
  const uint64_t v = playing.connect(viewer, Role::viewer, "");
  EXPECT_NE(viewer->json("serverInfo")[0].DebugString().find("clientPublish"), std::string::npos);
  playing.receive_text(
      v, R"({"op":"advertise","channels":[{"id":1,"topic":"/poses","encoding":"json","schemaName":"P"}]})");
  EXPECT_EQ(viewer->statuses().back(),
            "PERMISSION_DENIED: publishing needs the operator role; this connection is viewer");

  auto op = std::make_shared<RecordingOutbox>();
  const uint64_t o = playing.connect(op, Role::operator_, "");
  playing.receive_text(o,
                       R"({"op":"advertise","channels":[{"id":1,"topic":"/poses","encoding":"json","schemaName":"P"},)"
                       R"({"id":2,"topic":"/nowhere","encoding":"json","schemaName":"N"},)"
                       R"({"id":3,"topic":"/x","encoding":"cdr","schemaName":"X"},)"
                       R"({"id":4,"topic":"/y","encoding":"json","schemaName":"Y"}]})");
  ASSERT_EQ(op->statuses().size(), 2u);
  EXPECT_EQ(op->statuses()[0], "advertise: channel 3 (/x): encoding 'cdr' is not supported (supportedEncodings: json)");
  EXPECT_EQ(op->statuses()[1], "advertise: at most 2 channels per connection");
  playing.receive_binary(o, std::string("\x01\x01\x00\x00\x00", 5) + R"({"x":1})");
  ASSERT_EQ(taken.size(), 1u);
  EXPECT_EQ(std::get<0>(taken[0]), "/poses");
  EXPECT_EQ(std::get<1>(taken[0]), "P");
  EXPECT_EQ(std::get<2>(taken[0]), R"({"x":1})");
  playing.receive_binary(o, std::string("\x01\x02\x00\x00\x00", 5) + "{}");
  EXPECT_EQ(op->statuses().back(), "/nowhere: not a topic of the gateway");
  playing.receive_binary(o, std::string("\x01\x09\x00\x00\x00", 5) + "{}");
  EXPECT_EQ(op->statuses().back(), "client message data: unknown channel 9 (advertise it first)");
  playing.receive_text(o, R"({"op":"unadvertise","channelIds":[1]})");
  playing.receive_binary(o, std::string("\x01\x01\x00\x00\x00", 5) + "{}");
  EXPECT_EQ(op->statuses().back(), "client message data: unknown channel 1 (advertise it first)");
  EXPECT_EQ(taken.size(), 1u);
}
