// The gateway's picture against in-memory sources and client: what each source reports becomes
// channels, services and the connection graph.
#include "urs/gateway/gateway.hpp"

#include <google/protobuf/struct.pb.h>
#include <google/protobuf/util/json_util.h>
#include <gtest/gtest.h>

#include <mutex>

#include "Diagnostic.pb.h"
#include "urs/schema/json.hpp"

namespace gp = google::protobuf;
namespace gw = urs::gateway;

namespace {

class Outbox : public gw::Outbox {
 public:
  bool send_text(std::string text) override {
    std::lock_guard lock(mutex);
    texts.push_back(std::move(text));
    return true;
  }
  bool send_binary(std::string header, std::shared_ptr<const std::string> payload) override {
    std::lock_guard lock(mutex);
    if (!header.empty() && header[0] == 0x03) responses.push_back(header);
    if (!header.empty() && header[0] == 0x01 && payload) {
      uint32_t id = 0;
      for (int i = 3; i >= 0; --i) id = (id << 8) | static_cast<uint8_t>(header[1 + i]);
      data.emplace_back(id, *payload);
    }
    return true;
  }
  std::vector<gp::Struct> json(const std::string& op) {
    std::lock_guard lock(mutex);
    std::vector<gp::Struct> out;
    for (const auto& text : texts) {
      gp::Value value;
      if (gp::util::JsonStringToMessage(text, &value).ok() &&
          value.struct_value().fields().at("op").string_value() == op) {
        out.push_back(value.struct_value());
      }
    }
    return out;
  }
  // The payloads sent on subscription `id`, parsed.
  std::vector<gp::Struct> on(uint32_t id) {
    std::lock_guard lock(mutex);
    std::vector<gp::Struct> out;
    for (const auto& [sub, payload] : data) {
      gp::Value value;
      if (sub == id && gp::util::JsonStringToMessage(payload, &value).ok()) out.push_back(value.struct_value());
    }
    return out;
  }
  std::mutex mutex;
  std::vector<std::string> texts;
  std::vector<std::pair<uint32_t, std::string>> data;
  std::vector<std::string> responses;  // service call responses, whole
};

gw::Service service(const std::string& space, const std::string& name, const std::string& bridge = {}) {
  gw::Service s;
  s.set_space(space);
  s.set_name(name);
  s.set_interface("URS.Diagnostic");
  s.set_origin("camus");
  s.set_bridge(bridge);
  s.set_seen_via("camus");
  return s;
}

gw::Operation echo(const std::string& name, std::string answer) {
  gw::Operation op;
  op.name = name + "/echo";
  op.type = "URS.Diagnostic.echo";
  op.space = "lab";
  op.service = name;
  op.request = URS::Diagnostic_echo_Request::descriptor();
  op.response = URS::Diagnostic_echo_Reply::descriptor();
  op.handler = [answer](const gw::Caller&, std::string, std::function<void(gw::CallReply)> reply) {
    reply(gw::CallReply::success(answer));
  };
  return op;
}

std::string subscribe(uint32_t id, uint32_t channel) {
  return "{\"op\":\"subscribe\",\"subscriptions\":[{\"id\":" + std::to_string(id) +
         ",\"channelId\":" + std::to_string(channel) + "}]}";
}

std::string call(uint32_t service, uint32_t call_id) {
  std::string out(1, '\x02');
  for (uint32_t v : {service, call_id, 4u}) {
    for (int i = 0; i < 4; ++i) out += static_cast<char>((v >> (8 * i)) & 0xff);
  }
  return out + "json{}";
}

class GatewayTest : public ::testing::Test {
 protected:
  gw::Hub hub{gw::HubOptions{}};
  gw::Gateway gateway{gw::GatewayOptions{"lab", {"camus", "rtc"}, true, 7}, hub};
  std::shared_ptr<Outbox> client = std::make_shared<Outbox>();
  uint64_t id = hub.connect(client, gw::Role::operator_, "");
};

}  // namespace

TEST_F(GatewayTest, EachSourceReplacesItsOwnPart) {
  hub.receive_text(id, subscribe(1, gateway.channel("/services")));
  gateway.services("camus", {service("lab", "diag"), service("lab", "tts")});
  gateway.services("dds", {service("jp", "robot1.navigation", "bridge-jp")});
  gateway.services("camus", {service("lab", "diag")});  // tts left
  const auto snapshots = client->on(1);
  ASSERT_FALSE(snapshots.empty());
  const auto& last = snapshots.back().fields().at("services").list_value();
  ASSERT_EQ(last.values_size(), 2);
  std::set<std::string> names;
  for (const auto& s : last.values())
    names.insert(s.struct_value().fields().at("space").string_value() + "/" +
                 s.struct_value().fields().at("name").string_value());
  EXPECT_EQ(names, (std::set<std::string>{"lab/diag", "jp/robot1.navigation"}));
  // The same picture again is not sent again.
  const std::size_t sent = client->on(1).size();
  gateway.services("camus", {service("lab", "diag")});
  EXPECT_EQ(client->on(1).size(), sent);
}

TEST_F(GatewayTest, OperationsBecomeServicesThatKeepTheirIds) {
  gateway.operations("camus", {echo("diag", "{\"result\":\"first\"}")});
  auto advertised = client->json("advertiseServices");
  ASSERT_EQ(advertised.size(), 1u);
  const auto& first = advertised[0].fields().at("services").list_value().values(0).struct_value().fields();
  EXPECT_EQ(first.at("name").string_value(), "diag/echo");
  EXPECT_EQ(first.at("request").struct_value().fields().at("schemaName").string_value(), "URS.Diagnostic_echo_Request");
  const auto service_id = static_cast<uint32_t>(first.at("id").number_value());
  // A source reporting the same operation with a new handler: the same service, the new handler.
  gateway.operations("camus", {echo("diag", "{\"result\":\"second\"}")});
  EXPECT_EQ(client->json("advertiseServices").size(), 1u);
  EXPECT_TRUE(client->json("unadvertiseServices").empty());
  hub.receive_binary(id, call(service_id, 1));
  ASSERT_EQ(client->responses.size(), 1u);
  EXPECT_NE(client->responses[0].find("{\"result\":\"second\"}"), std::string::npos) << client->responses[0];
  EXPECT_TRUE(client->json("serviceCallFailure").empty());
  // The services table says which operations call each service.
  hub.receive_text(id, subscribe(2, gateway.channel("/services")));
  gateway.services("camus", {service("lab", "diag")});
  const auto table = client->on(2).back().fields().at("services").list_value().values(0).struct_value().fields();
  EXPECT_EQ(table.at("operations").list_value().values(0).string_value(), "diag/echo");
  // Gone from its source: unadvertised.
  gateway.operations("camus", {});
  ASSERT_EQ(client->json("unadvertiseServices").size(), 1u);
  EXPECT_EQ(client->json("unadvertiseServices")[0].fields().at("serviceIds").list_value().values(0).number_value(),
            service_id);
}

TEST_F(GatewayTest, PosesGoToTheAggregateAndTheRobotsOwnChannel) {
  hub.receive_text(id, subscribe(1, gateway.channel("/poses")));
  gw::Pose pose = gw::pose_of("jp", "robot1", 1.5, 1.0, 0.1, std::chrono::system_clock::now(), "dds");
  gateway.pose(pose);
  auto channels = client->json("advertise");
  uint32_t own = 0;
  for (const auto& message : channels) {
    for (const auto& channel : message.fields().at("channels").list_value().values()) {
      if (channel.struct_value().fields().at("topic").string_value() == "/jp/robot1/pose") {
        own = static_cast<uint32_t>(channel.struct_value().fields().at("id").number_value());
      }
    }
  }
  ASSERT_NE(own, 0u) << "a channel of the robot's own";
  hub.receive_text(id, subscribe(2, own));
  EXPECT_EQ(client->on(2).size(), 1u) << "its last pose, latched";
  pose.set_x(2.0);
  gateway.pose(pose);
  ASSERT_EQ(client->on(1).size(), 2u);
  EXPECT_EQ(client->on(1).back().fields().at("x").number_value(), 2.0);
  EXPECT_EQ(client->on(2).back().fields().at("via").string_value(), "dds");
}

TEST_F(GatewayTest, TheGraphNamesSpacesBridgesAndTheLink) {
  hub.receive_text(id, subscribe(1, gateway.channel("/graph")));
  hub.receive_text(id, "{\"op\":\"subscribeConnectionGraph\"}");
  gateway.services("dds", {service("jp", "robot1.navigation", "bridge-jp")});
  const auto graph = client->on(1).back().fields();
  EXPECT_EQ(graph.at("space").string_value(), "lab");
  EXPECT_EQ(graph.at("dds_domain").number_value(), 7);
  const auto& spaces = graph.at("spaces").list_value();
  ASSERT_EQ(spaces.values_size(), 2);
  const auto& jp = spaces.values(0).struct_value().fields();
  EXPECT_EQ(jp.at("name").string_value(), "jp");
  EXPECT_EQ(jp.at("bridges").list_value().values(0).struct_value().fields().at("name").string_value(), "bridge-jp");
  EXPECT_TRUE(spaces.values(1).struct_value().fields().at("local").bool_value());
  bool advertised = false;
  for (const auto& update : client->json("connectionGraphUpdate")) {
    for (const auto& s : update.fields().at("advertisedServices").list_value().values()) {
      advertised = advertised || s.struct_value().fields().at("name").string_value() == "jp/robot1.navigation";
    }
  }
  EXPECT_TRUE(advertised);
}

TEST_F(GatewayTest, ContextKeysEndAndAreNotReplayed) {
  gw::ContextEntry entry;
  entry.set_space("lab");
  entry.set_key("room/light");
  entry.mutable_value()->set_bool_value(true);
  gateway.context(entry);
  entry.set_removed(true);
  gateway.context(entry);
  hub.receive_text(id, subscribe(1, gateway.channel("/context")));
  EXPECT_TRUE(client->on(1).empty());
}

TEST_F(GatewayTest, EachRobotsChannelIsInTheConnectionGraph) {
  hub.receive_text(id, "{\"op\":\"subscribeConnectionGraph\"}");
  gateway.pose(gw::pose_of("jp", "robot1", 1.5, 1.0, 0.1, std::chrono::system_clock::now(), "dds"));
  bool published = false;
  for (const auto& update : client->json("connectionGraphUpdate")) {
    for (const auto& t : update.fields().at("publishedTopics").list_value().values()) {
      const auto& topic = t.struct_value().fields();
      published = published || (topic.at("name").string_value() == "/jp/robot1/pose" &&
                                topic.at("publisherIds").list_value().values(0).string_value() == "space:jp");
    }
  }
  EXPECT_TRUE(published);
}

TEST_F(GatewayTest, ValueFieldsOfCallsTravelAsJsonText) {
  gw::Operation op;
  op.name = "ctx/Echo";
  op.type = "Test.Echo";
  op.space = "lab";
  op.service = "ctx";
  op.request = gw::ContextEntry::descriptor();
  op.response = gw::ContextEntry::descriptor();
  std::string received;
  op.handler = [&received](const gw::Caller&, std::string json, std::function<void(gw::CallReply)> reply) {
    received = json;
    reply(gw::CallReply::success(json));  // the canonical form back
  };
  gateway.operations("camus", {op});
  const auto advertised = client->json("advertiseServices");
  ASSERT_EQ(advertised.size(), 1u);
  const auto service_id = static_cast<uint32_t>(
      advertised[0].fields().at("services").list_value().values(0).struct_value().fields().at("id").number_value());
  std::string request(1, '\x02');
  for (uint32_t v : {service_id, 5u, 4u}) {
    for (int i = 0; i < 4; ++i) request += static_cast<char>((v >> (8 * i)) & 0xff);
  }
  hub.receive_binary(id, request + "json" + R"({"key":"k","value":"[1,2]"})");
  gw::ContextEntry entry;
  ASSERT_EQ(urs::schema::json_to_message(received, entry), "") << received;
  EXPECT_EQ(entry.value().list_value().values_size(), 2) << "the handler got the value itself";
  ASSERT_EQ(client->responses.size(), 1u);
  EXPECT_NE(client->responses[0].find(R"("value":"[1,2]")"), std::string::npos) << "the reply carries JSON text";
}
