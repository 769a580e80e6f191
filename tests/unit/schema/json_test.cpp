// Dynamic invocation: JSON -> dynamic message (described by urs::idl's .desc) -> bytes -> the
// generated C++ type, and back; errors name the field or value.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <memory>

#include "Diagnostic.pb.h"
#include "ImageRecognition.pb.h"
#include "test_paths.hpp"
#include "urs/schema/schema.hpp"

namespace urs::schema {
namespace {

namespace gp = google::protobuf;
using ::testing::HasSubstr;

class Json : public ::testing::Test {
 protected:
  void SetUp() override { ASSERT_EQ(pool_.add_descriptor_set(test::read_file(test::kIdlDescriptorSet)), ""); }

  std::unique_ptr<gp::Message> make(const std::string& type) {
    const gp::Descriptor* d = pool_.find_message(type);
    EXPECT_NE(d, nullptr) << type;
    return pool_.new_message(*d);
  }

  SchemaPool pool_;
};

TEST_F(Json, JsonToDynamicMessageToGeneratedType) {
  const gp::MethodDescriptor* add = pool_.find_method("URS.Diagnostic.add");
  ASSERT_NE(add, nullptr);
  auto request = pool_.new_message(*add->input_type());
  ASSERT_EQ(json_to_message(R"({"a": 1.5, "b": -2.25})", *request), "");
  URS::Diagnostic_add_Request compiled;
  ASSERT_TRUE(compiled.ParseFromString(request->SerializeAsString()));
  EXPECT_EQ(compiled.a(), 1.5);
  EXPECT_EQ(compiled.b(), -2.25);

  URS::Diagnostic_add_Request expected;
  expected.set_a(1.5);
  expected.set_b(-2.25);
  EXPECT_EQ(request->SerializeAsString(), expected.SerializeAsString());
}

TEST_F(Json, GeneratedTypeToDynamicMessageToJson) {
  URS::Diagnostic_checksum_Reply reply;
  reply.set_result(9223372036854775813ull);  // beyond 2^53: printed as a string, exactly
  auto dynamic = make("URS.Diagnostic_checksum_Reply");
  ASSERT_TRUE(dynamic->ParseFromString(reply.SerializeAsString()));
  std::string json;
  ASSERT_EQ(message_to_json(*dynamic, json), "");
  EXPECT_EQ(json, R"({"result":"9223372036854775813"})");

  URS::Diagnostic_blob_Reply blob;
  blob.set_result(std::string("\x00\x01\x02", 3));
  auto dynamic_blob = make("URS.Diagnostic_blob_Reply");
  ASSERT_TRUE(dynamic_blob->ParseFromString(blob.SerializeAsString()));
  ASSERT_EQ(message_to_json(*dynamic_blob, json), "");
  EXPECT_EQ(json, R"({"result":"AAEC"})");  // bytes: base64
}

TEST_F(Json, DefaultsEnumsAndIdlFieldNamesArePrinted) {
  URC::ImageFormat format;
  format.set_width(640);
  format.set_encoding(URC::IMAGE_ENCODING_PNG);
  auto dynamic = make("URC.ImageFormat");
  ASSERT_TRUE(dynamic->ParseFromString(format.SerializeAsString()));
  std::string json;
  ASSERT_EQ(message_to_json(*dynamic, json), "");
  EXPECT_EQ(json, R"({"width":640,"height":0,"encoding":"IMAGE_ENCODING_PNG"})");
  ASSERT_EQ(message_to_json(*dynamic, json, true), "");
  EXPECT_THAT(json, HasSubstr("\n \"width\": 640"));

  auto request = make("URC.Navigation_setSpeed_Request");
  ASSERT_EQ(json_to_message(R"({"speed": 500})", *request), "");
  auto image = make("URC.ImageRecognition_captureImage_Request");
  ASSERT_EQ(json_to_message(R"({"encoding": "IMAGE_ENCODING_JPEG"})", *image), "");
  URC::ImageRecognition_captureImage_Request compiled;
  ASSERT_TRUE(compiled.ParseFromString(image->SerializeAsString()));
  EXPECT_EQ(compiled.encoding(), URC::IMAGE_ENCODING_JPEG);
}

TEST_F(Json, WrongTypeNamesTheField) {
  auto request = make("URS.Diagnostic_add_Request");
  const std::string error = json_to_message(R"({"a": "one", "b": 2})", *request);
  EXPECT_THAT(error, HasSubstr("JSON for URS.Diagnostic_add_Request: "));
  EXPECT_THAT(error, HasSubstr("(a)"));
  EXPECT_THAT(error, HasSubstr("one"));
}

TEST_F(Json, UnknownFieldIsNamed) {
  auto request = make("URS.Diagnostic_echo_Request");
  const std::string error = json_to_message(R"({"txt": "hello"})", *request);
  EXPECT_THAT(error, HasSubstr("JSON for URS.Diagnostic_echo_Request: "));
  EXPECT_THAT(error, HasSubstr("txt"));
}

TEST_F(Json, OutOfRangeValueIsNamed) {
  auto request = make("URS.Diagnostic_sleep_Request");  // unsigned long ms
  const std::string error = json_to_message(R"({"ms": -1})", *request);
  EXPECT_THAT(error, HasSubstr("(ms)"));
  EXPECT_THAT(error, HasSubstr("-1"));
}

TEST_F(Json, MalformedJsonIsAnError) {
  auto request = make("URS.Diagnostic_echo_Request");
  EXPECT_THAT(json_to_message(R"({"text": )", *request), HasSubstr("JSON for URS.Diagnostic_echo_Request: "));
  EXPECT_THAT(json_to_message("[1, 2]", *request), HasSubstr("JSON for URS.Diagnostic_echo_Request: "));
}

TEST_F(Json, RoundTripsEveryFieldOfANestedMessage) {
  const std::string in = R"({"result":{"format":{"width":640,"height":480,"encoding":"IMAGE_ENCODING_RAW_RGB8"},)"
                         R"("stamp":{"sec":"1700000000","nsec":5},"data":"AAEC"}})";
  auto reply = make("URC.ImageRecognition_captureImage_Reply");
  ASSERT_EQ(json_to_message(in, *reply), "");
  std::string out;
  ASSERT_EQ(message_to_json(*reply, out), "");
  EXPECT_EQ(out, in);
  URC::ImageRecognition_captureImage_Reply compiled;
  ASSERT_TRUE(compiled.ParseFromString(reply->SerializeAsString()));
  EXPECT_EQ(compiled.result().format().height(), 480u);
  EXPECT_EQ(compiled.result().stamp().sec(), 1700000000);
  EXPECT_EQ(compiled.result().data(), std::string("\x00\x01\x02", 3));
}

}  // namespace
}  // namespace urs::schema
