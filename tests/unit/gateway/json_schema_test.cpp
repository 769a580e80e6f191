// JSON schemas are derived from descriptors alone and say what the canonical JSON mapping prints.
#include "urs/gateway/json_schema.hpp"

#include <google/protobuf/struct.pb.h>
#include <google/protobuf/util/json_util.h>
#include <gtest/gtest.h>

#include "AllTypes.pb.h"
#include "Diagnostic.pb.h"
#include "gateway.pb.h"
#include "urs/schema/json.hpp"

namespace gp = google::protobuf;
using urs::gateway::json_schema;

namespace {

gp::Struct schema_of(const gp::Descriptor& type) {
  gp::Value value;
  const std::string text = json_schema(type);
  EXPECT_TRUE(gp::util::JsonStringToMessage(text, &value).ok()) << text;
  return value.struct_value();
}

const gp::Struct& object(const gp::Struct& s, const std::string& key) { return s.fields().at(key).struct_value(); }
std::string type_of(const gp::Struct& property) {
  const gp::Value& type = property.fields().at("type");
  return type.kind_case() == gp::Value::kStringValue ? type.string_value() : "(list)";
}

// Every key the JSON mapping prints for `message` is a property of its schema, recursively (an
// object cut at a recursion lists none).
void expect_described(const gp::Struct& printed, const gp::Struct& schema, const std::string& where) {
  const gp::Struct* s = &schema;
  ASSERT_TRUE(s->fields().count("properties")) << where;
  if (object(*s, "properties").fields().empty() && !s->fields().count("additionalProperties")) return;
  const gp::Struct& properties = object(*s, "properties");
  for (const auto& [key, value] : printed.fields()) {
    ASSERT_TRUE(properties.fields().count(key)) << where << "." << key << " is printed but not in the schema";
    const gp::Struct& property = properties.fields().at(key).struct_value();
    if (value.kind_case() == gp::Value::kStructValue && property.fields().count("properties")) {
      expect_described(value.struct_value(), property, where + "." + key);
    }
    if (value.kind_case() == gp::Value::kListValue) {
      EXPECT_EQ(type_of(property), "array") << where << "." << key;
      const gp::Struct& items = object(property, "items");
      for (const auto& item : value.list_value().values()) {
        if (item.kind_case() == gp::Value::kStructValue)
          expect_described(item.struct_value(), items, where + "." + key + "[]");
      }
    }
  }
}

}  // namespace

TEST(JsonSchema, ScalarsMapToTheirJsonTypes) {
  const gp::Struct schema = schema_of(*UrsTest::Scalars::descriptor());
  EXPECT_EQ(schema.fields().at("title").string_value(), "UrsTest.Scalars");
  EXPECT_EQ(type_of(schema), "object");
  EXPECT_FALSE(schema.fields().at("additionalProperties").bool_value());
  const gp::Struct& p = object(schema, "properties");
  EXPECT_EQ(type_of(object(p, "l")), "integer");
  EXPECT_EQ(object(p, "l").fields().at("minimum").number_value(), -2147483648.0);
  EXPECT_EQ(object(p, "ul").fields().at("maximum").number_value(), 4294967295.0);
  EXPECT_EQ(type_of(object(p, "d")), "number");
  EXPECT_EQ(type_of(object(p, "b")), "boolean");
  EXPECT_EQ(type_of(object(p, "str")), "string");
  // 64-bit integers print as decimal strings: one type, as Foxglove and Lichtblick require.
  EXPECT_EQ(type_of(object(p, "ll")), "string");
  EXPECT_EQ(object(p, "ull").fields().at("pattern").string_value(), "^[0-9]+$");
}

TEST(JsonSchema, ContainersEnumsBytesAndNestedMessages) {
  const gp::Struct schema = schema_of(*UrsTest::Containers::descriptor());
  const gp::Struct& p = object(schema, "properties");
  EXPECT_EQ(object(p, "blob").fields().at("contentEncoding").string_value(), "base64");
  EXPECT_EQ(type_of(object(p, "longs")), "array");
  EXPECT_EQ(type_of(object(object(p, "longs"), "items")), "integer");
  EXPECT_EQ(type_of(object(object(p, "colors"), "items")), "string");
  const auto& colors = object(object(p, "colors"), "items").fields().at("enum").list_value();
  ASSERT_EQ(colors.values_size(), 3);
  EXPECT_EQ(colors.values(2).string_value(), "COLOR_LIGHT_BLUE");
  const gp::Struct& point = object(object(p, "points"), "items");
  EXPECT_EQ(point.fields().at("title").string_value(), "UrsTest.Point");
  EXPECT_TRUE(object(point, "properties").fields().count("x"));
}

TEST(JsonSchema, RecursiveTypesAreCutWhereTheyRecur) {
  // Neither Foxglove nor Lichtblick follows "$ref": the type inside itself is any object.
  const gp::Struct schema = schema_of(*UrsTest::Node::descriptor());
  EXPECT_FALSE(schema.fields().count("$defs"));
  const gp::Struct& items = object(object(object(schema, "properties"), "children"), "items");
  EXPECT_EQ(type_of(items), "object");
  EXPECT_EQ(items.fields().at("title").string_value(), "UrsTest.Node");
  EXPECT_TRUE(object(items, "properties").fields().empty());
}

TEST(JsonSchema, BytesInAnArrayHaveAPatternNotAnEncoding) {
  const gp::Struct schema = schema_of(*UrsTest::Containers::descriptor());
  const gp::Struct& digest = object(object(object(schema, "properties"), "chunks"), "items");
  EXPECT_FALSE(digest.fields().count("contentEncoding"));
  EXPECT_EQ(type_of(digest), "string");
}

TEST(JsonSchema, ValuesAreJsonTextAndStructsObjects) {
  const gp::Struct schema = schema_of(*urs::gateway::ContextEntry::descriptor());
  const gp::Struct& value = object(object(schema, "properties"), "value");
  EXPECT_EQ(value.fields().at("title").string_value(), "google.protobuf.Value");
  EXPECT_EQ(type_of(value), "string");
  EXPECT_EQ(value.fields().at("contentMediaType").string_value(), "application/json");
  const gp::Struct any = schema_of(*gp::Struct::descriptor());
  EXPECT_EQ(type_of(any), "object");
  EXPECT_TRUE(any.fields().count("properties"));
}

TEST(JsonSchema, EveryPrintedFieldIsDescribed) {
  UrsTest::Node tree;
  tree.set_name("root");
  tree.add_children()->add_children()->set_name("leaf");
  UrsTest::Containers containers;
  containers.add_points()->set_x(1);
  containers.add_colors(UrsTest::COLOR_GREEN);
  containers.add_nested()->add_items(3);
  urs::gateway::Components components;
  auto* component = components.add_components();
  component->set_name("jp1.host_cxt/Robot0.rtc");
  component->add_ports()->add_connections()->add_ports("a:b");
  URS::Diagnostic_echo_Request echo;
  echo.set_text("hi");
  for (const gp::Message* message : std::initializer_list<const gp::Message*>{&tree, &containers, &components, &echo}) {
    std::string json;
    ASSERT_EQ(urs::schema::message_to_json(*message, json), "");
    gp::Value printed;
    ASSERT_TRUE(gp::util::JsonStringToMessage(json, &printed).ok());
    const gp::Struct schema = schema_of(*message->GetDescriptor());
    expect_described(printed.struct_value(), schema, message->GetDescriptor()->full_name());
  }
}
