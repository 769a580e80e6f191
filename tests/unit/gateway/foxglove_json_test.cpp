// The Foxglove side's JSON: the canonical mapping, but google.protobuf.Value and ListValue fields
// travel as their JSON text, both ways, at any depth; what json_schema() says of them.
#include "urs/gateway/foxglove_json.hpp"

#include <google/protobuf/struct.pb.h>
#include <google/protobuf/util/json_util.h>
#include <gtest/gtest.h>

#include "Diagnostic.pb.h"
#include "gateway.pb.h"
#include "urs/schema/json.hpp"

namespace gp = google::protobuf;
namespace gw = urs::gateway;

namespace {
gp::Struct parsed(const std::string& json) {
  gp::Value value;
  EXPECT_TRUE(gp::util::JsonStringToMessage(json, &value).ok()) << json;
  return value.struct_value();
}
}  // namespace

TEST(FoxgloveJson, OnlyTypesWithValuesDifferFromTheCanonicalMapping) {
  EXPECT_TRUE(gw::has_json_text_fields(*gw::ContextEntry::descriptor()));
  EXPECT_TRUE(gw::has_json_text_fields(*gw::Event::descriptor()));
  EXPECT_FALSE(gw::has_json_text_fields(*gw::Pose::descriptor()));
  EXPECT_FALSE(gw::has_json_text_fields(*gw::Components::descriptor()));
  gw::Pose pose;
  pose.set_robot("robot1");
  pose.set_x(1.25);
  std::string canonical, foxglove;
  ASSERT_EQ(urs::schema::message_to_json(pose, canonical), "");
  ASSERT_EQ(gw::to_foxglove_json(pose, foxglove), "");
  EXPECT_EQ(foxglove, canonical);
}

TEST(FoxgloveJson, ValuesArePrintedAsTheirJsonText) {
  gw::Event event;
  event.set_topic("camera1/marker");
  auto& fields = *event.mutable_payload()->mutable_struct_value()->mutable_fields();
  fields["text"].set_string_value("hi");
  fields["n"].set_number_value(3);
  std::string json;
  ASSERT_EQ(gw::to_foxglove_json(event, json), "");
  const gp::Struct printed = parsed(json);
  ASSERT_EQ(printed.fields().at("payload").kind_case(), gp::Value::kStringValue) << json;
  const gp::Struct payload = parsed(printed.fields().at("payload").string_value());
  EXPECT_EQ(payload.fields().at("text").string_value(), "hi");
  EXPECT_EQ(payload.fields().at("n").number_value(), 3);
  EXPECT_EQ(printed.fields().at("topic").string_value(), "camera1/marker");
}

TEST(FoxgloveJson, JsonTextIsReadBackAndTheValueItselfStillAccepted) {
  const auto& type = *gw::ContextEntry::descriptor();
  for (const char* sent : {R"({"key":"k","value":"{\"on\":true}"})", R"({"key":"k","value":{"on":true}})"}) {
    std::string canonical;
    ASSERT_EQ(gw::from_foxglove_json(sent, type, canonical), "") << sent;
    gw::ContextEntry entry;
    ASSERT_EQ(urs::schema::json_to_message(canonical, entry), "") << canonical;
    EXPECT_TRUE(entry.value().struct_value().fields().at("on").bool_value()) << sent;
  }
  std::string canonical;
  ASSERT_EQ(gw::from_foxglove_json(R"({"value":"\"a string\""})", type, canonical), "");
  gw::ContextEntry entry;
  ASSERT_EQ(urs::schema::json_to_message(canonical, entry), "");
  EXPECT_EQ(entry.value().string_value(), "a string");
}

TEST(FoxgloveJson, TextThatIsNotJsonIsRefusedNamingTheField) {
  std::string out;
  const std::string error =
      gw::from_foxglove_json(R"({"key":"k","value":"not json"})", *gw::ContextEntry::descriptor(), out);
  EXPECT_EQ(error.rfind("JSON for urs.gateway.ContextEntry: value: not JSON text (a google.protobuf.Value is sent as "
                        "its JSON text)",
                        0),
            0u)
      << error;
  EXPECT_NE(gw::from_foxglove_json("{", *gw::ContextEntry::descriptor(), out), "");
}

TEST(FoxgloveJson, OtherTypesPassUntouched) {
  std::string out;
  ASSERT_EQ(gw::from_foxglove_json(R"({"text":"hi"})", *URS::Diagnostic_echo_Request::descriptor(), out), "");
  EXPECT_EQ(out, R"({"text":"hi"})");
}
