// The Foxglove WebSocket protocol as foxglove/ws-protocol docs/spec.md gives it: what clients send
// is parsed (and refused with a precise reason), what the server sends is laid out byte for byte.
#include "urs/gateway/protocol.hpp"

#include <google/protobuf/struct.pb.h>
#include <google/protobuf/util/json_util.h>
#include <gtest/gtest.h>

namespace fg = urs::gateway::foxglove;
namespace gp = google::protobuf;

namespace {

gp::Struct parsed(const std::string& json) {
  gp::Value value;
  EXPECT_TRUE(gp::util::JsonStringToMessage(json, &value).ok()) << json;
  return value.struct_value();
}

std::string error_of(const fg::ClientMessage& message) {
  auto* error = std::get_if<fg::ProtocolError>(&message);
  return error ? error->message : "(no error)";
}

std::string bytes(std::initializer_list<int> values) {
  std::string out;
  for (int v : values) out += static_cast<char>(v);
  return out;
}

}  // namespace

TEST(FoxgloveParse, SubscribeCarriesEverySubscription) {
  auto message =
      fg::parse_text(R"({"op":"subscribe","subscriptions":[{"id":0,"channelId":3},{"id":1,"channelId":5}]})");
  auto* subscribe = std::get_if<fg::Subscribe>(&message);
  ASSERT_NE(subscribe, nullptr) << error_of(message);
  ASSERT_EQ(subscribe->subscriptions.size(), 2u);
  EXPECT_EQ(subscribe->subscriptions[1].id, 1u);
  EXPECT_EQ(subscribe->subscriptions[1].channel_id, 5u);
}

TEST(FoxgloveParse, UnsubscribeAndGraphOps) {
  auto message = fg::parse_text(R"({"op":"unsubscribe","subscriptionIds":[0,4294967295]})");
  auto* unsubscribe = std::get_if<fg::Unsubscribe>(&message);
  ASSERT_NE(unsubscribe, nullptr) << error_of(message);
  EXPECT_EQ(unsubscribe->subscription_ids, (std::vector<uint32_t>{0, 4294967295u}));
  EXPECT_TRUE(
      std::holds_alternative<fg::SubscribeConnectionGraph>(fg::parse_text(R"({"op":"subscribeConnectionGraph"})")));
  EXPECT_TRUE(
      std::holds_alternative<fg::UnsubscribeConnectionGraph>(fg::parse_text(R"({"op":"unsubscribeConnectionGraph"})")));
}

TEST(FoxgloveParse, BadInputIsRefusedWithItsReason) {
  EXPECT_EQ(error_of(fg::parse_text("{not json")).rfind("not JSON", 0), 0u);
  EXPECT_EQ(error_of(fg::parse_text("[1,2]")), "a message must be a JSON object");
  EXPECT_EQ(error_of(fg::parse_text(R"({"subscriptions":[]})")), "a message must have a string field 'op'");
  EXPECT_EQ(error_of(fg::parse_text(R"({"op":"fly"})")), "unknown op 'fly'");
  EXPECT_EQ(error_of(fg::parse_text(R"({"op":"subscribe"})")), "subscribe: 'subscriptions' must be an array");
  EXPECT_EQ(error_of(fg::parse_text(R"({"op":"subscribe","subscriptions":[{"id":1,"channelId":-1}]})")),
            "subscribe: subscriptions[0].channelId must be an integer in 0..4294967295");
  EXPECT_EQ(error_of(fg::parse_text(R"({"op":"subscribe","subscriptions":[{"id":1.5,"channelId":1}]})")),
            "subscribe: subscriptions[0].id must be an integer in 0..4294967295");
  EXPECT_EQ(error_of(fg::parse_text(R"({"op":"unsubscribe","subscriptionIds":["a"]})")),
            "unsubscribe: subscriptionIds[0] must be an integer in 0..4294967295");
  std::string many = R"({"op":"unsubscribe","subscriptionIds":[)";
  for (int i = 0; i < 1025; ++i) many += (i ? ",1" : "1");
  EXPECT_EQ(error_of(fg::parse_text(many + "]}")), "unsubscribe: 1025 ids in one message (at most 1024)");
  EXPECT_EQ(error_of(fg::parse_text(std::string(fg::kMaxTextMessage + 1, ' '))),
            "message of 65537 bytes (at most 65536)");
  // Deep nesting is refused by the JSON parser, not by a crash.
  EXPECT_EQ(error_of(fg::parse_text(std::string(5000, '[') + std::string(5000, ']'))).rfind("not JSON", 0), 0u);
}

TEST(FoxgloveParse, OperationsOfOtherCapabilitiesAreUnsupported) {
  for (const char* op : {"getParameters", "setParameters", "fetchAsset"}) {
    auto message = fg::parse_text(std::string(R"({"op":")") + op + "\"}");
    auto* unsupported = std::get_if<fg::Unsupported>(&message);
    ASSERT_NE(unsupported, nullptr) << op;
    EXPECT_EQ(unsupported->op, op);
  }
}

TEST(FoxgloveParse, ClientPublishMessages) {
  auto message = fg::parse_text(
      R"({"op":"advertise","channels":[{"id":3,"topic":"/poses","encoding":"json","schemaName":"urs.gateway.Pose",
          "schema":"{}"}]})");
  auto* advertise = std::get_if<fg::ClientAdvertise>(&message);
  ASSERT_NE(advertise, nullptr) << error_of(message);
  ASSERT_EQ(advertise->channels.size(), 1u);
  EXPECT_EQ(advertise->channels[0].id, 3u);
  EXPECT_EQ(advertise->channels[0].topic, "/poses");
  EXPECT_EQ(advertise->channels[0].schema_name, "urs.gateway.Pose");
  message = fg::parse_text(R"({"op":"unadvertise","channelIds":[3,4]})");
  ASSERT_NE(std::get_if<fg::ClientUnadvertise>(&message), nullptr) << error_of(message);
  EXPECT_EQ(std::get<fg::ClientUnadvertise>(message).channel_ids.size(), 2u);
  auto data = fg::parse_binary(bytes({0x01, 3, 0, 0, 0}) + "{\"x\":1}");
  ASSERT_NE(std::get_if<fg::ClientMessageData>(&data), nullptr) << error_of(data);
  EXPECT_EQ(std::get<fg::ClientMessageData>(data).channel_id, 3u);
  EXPECT_EQ(std::get<fg::ClientMessageData>(data).payload, "{\"x\":1}");
  // Refusals name the field.
  EXPECT_EQ(error_of(fg::parse_text(R"({"op":"advertise","channels":[{"id":1,"encoding":"json","schemaName":"s"}]})")),
            "advertise: channels[0].topic must be a string");
  EXPECT_EQ(error_of(fg::parse_text(R"({"op":"advertise","channels":[{"id":1,"topic":"","encoding":"json",)"
                                    R"("schemaName":"s"}]})")),
            "advertise: channels[0].topic must have 1..256 bytes");
  EXPECT_EQ(error_of(fg::parse_text(R"({"op":"advertise","channels":[{"id":-1}]})")),
            "advertise: channels[0].id must be an integer in 0..4294967295");
  EXPECT_EQ(error_of(fg::parse_binary(bytes({0x01, 3, 0}))), "client message data: 3 bytes (at least 5)");
}

TEST(FoxgloveParse, ServiceCallRequestLayout) {
  // opcode 2, service 7, call 9, encoding "json", payload {}
  const std::string frame = bytes({0x02, 7, 0, 0, 0, 9, 0, 0, 0, 4, 0, 0, 0}) + "json{}";
  auto message = fg::parse_binary(frame);
  auto* call = std::get_if<fg::ServiceCallRequest>(&message);
  ASSERT_NE(call, nullptr) << error_of(message);
  EXPECT_EQ(call->service_id, 7u);
  EXPECT_EQ(call->call_id, 9u);
  EXPECT_EQ(call->encoding, "json");
  EXPECT_EQ(call->payload, "{}");
}

TEST(FoxgloveParse, BadBinaryInputIsRefused) {
  EXPECT_EQ(error_of(fg::parse_binary("")), "empty binary message");
  EXPECT_EQ(error_of(fg::parse_binary(bytes({0x09}))), "unknown binary opcode 9");
  EXPECT_EQ(error_of(fg::parse_binary(bytes({0x02, 1, 0, 0}))), "service call request: 4 bytes (at least 13)");
  EXPECT_EQ(error_of(fg::parse_binary(bytes({0x02, 1, 0, 0, 0, 1, 0, 0, 0, 5, 0, 0, 0}) + "json")),
            "service call request: encoding length 5 exceeds the message or 64 bytes");
  EXPECT_EQ(error_of(fg::parse_binary(bytes({0x02, 1, 0, 0, 0, 1, 0, 0, 0, -1, -1, -1, -1}) + "json")),
            "service call request: encoding length 4294967295 exceeds the message or 64 bytes");
}

TEST(FoxgloveEncode, MessageDataHeaderIsLittleEndian) {
  EXPECT_EQ(fg::message_data_header(0x01020304, 0x1122334455667788ull),
            bytes({0x01, 0x04, 0x03, 0x02, 0x01, 0x88, 0x77, 0x66, 0x55, 0x44, 0x33, 0x22, 0x11}));
}

TEST(FoxgloveEncode, ServiceCallResponseLayout) {
  EXPECT_EQ(fg::service_call_response(3, 258, "json", "{\"a\":1}"),
            bytes({0x03, 3, 0, 0, 0, 2, 1, 0, 0, 4, 0, 0, 0}) + "json{\"a\":1}");
}

TEST(FoxgloveEncode, JsonMessagesHaveTheSpecFields) {
  auto info = parsed(fg::server_info("gw", {"services", "connectionGraph"}, {"json"}, {{"space", "kr"}}, "s1"));
  EXPECT_EQ(info.fields().at("op").string_value(), "serverInfo");
  EXPECT_EQ(info.fields().at("capabilities").list_value().values(1).string_value(), "connectionGraph");
  EXPECT_EQ(info.fields().at("supportedEncodings").list_value().values(0).string_value(), "json");
  EXPECT_EQ(info.fields().at("metadata").struct_value().fields().at("space").string_value(), "kr");
  EXPECT_EQ(info.fields().at("sessionId").string_value(), "s1");

  auto status = parsed(fg::status(fg::StatusLevel::error, "bad \"thing\"\n"));
  EXPECT_EQ(status.fields().at("level").number_value(), 2);
  EXPECT_EQ(status.fields().at("message").string_value(), "bad \"thing\"\n");

  fg::Channel channel{4, "/poses", "json", "urs.gateway.Pose", "{\"type\":\"object\"}", "jsonschema"};
  auto advertise = parsed(fg::advertise({&channel}));
  const auto& advertised = advertise.fields().at("channels").list_value().values(0).struct_value().fields();
  EXPECT_EQ(advertised.at("id").number_value(), 4);
  EXPECT_EQ(advertised.at("topic").string_value(), "/poses");
  EXPECT_EQ(advertised.at("schemaEncoding").string_value(), "jsonschema");
  EXPECT_EQ(advertised.at("schema").string_value(), "{\"type\":\"object\"}");
  EXPECT_EQ(parsed(fg::unadvertise({4, 5})).fields().at("channelIds").list_value().values_size(), 2);

  fg::Service service{
      9, "diag/echo", "URS.Diagnostic.echo", {"json", "Req", "{}", "jsonschema"}, {"json", "Rep", "{}", "jsonschema"}};
  auto services = parsed(fg::advertise_services({&service}));
  const auto& one = services.fields().at("services").list_value().values(0).struct_value().fields();
  EXPECT_EQ(one.at("name").string_value(), "diag/echo");
  EXPECT_EQ(one.at("request").struct_value().fields().at("schemaName").string_value(), "Req");
  EXPECT_FALSE(one.count("requestSchema")) << "the deprecated form is not sent";
  EXPECT_FALSE(one.count("responseSchema"));
  auto failure = parsed(fg::service_call_failure(9, 2, "USER_EXCEPTION URS.Failure"));
  EXPECT_EQ(failure.fields().at("op").string_value(), "serviceCallFailure");
  EXPECT_EQ(failure.fields().at("callId").number_value(), 2);

  fg::GraphUpdate update;
  update.advertised_services.push_back({"jp/robot1.navigation", {"jp:bridge-jp"}});
  update.removed_topics.push_back("/old");
  auto graph = parsed(fg::connection_graph_update(update));
  EXPECT_EQ(graph.fields()
                .at("advertisedServices")
                .list_value()
                .values(0)
                .struct_value()
                .fields()
                .at("providerIds")
                .list_value()
                .values(0)
                .string_value(),
            "jp:bridge-jp");
  EXPECT_EQ(graph.fields().at("removedTopics").list_value().values(0).string_value(), "/old");
  EXPECT_EQ(graph.fields().at("publishedTopics").list_value().values_size(), 0);
}
