// The IDL -> Planet schema mapping, checked field by field on the schemas generated at build time
// from the test-only IDL files (idl/AllTypes.idl, Shared.idl, Nested.idl) and on urs::idl.
#include <gmock/gmock.h>
#include <google/protobuf/descriptor.pb.h>
#include <gtest/gtest.h>

#include "AllTypes.pb.h"
#include "Diagnostic.pb.h"
#include "ImageRecognition.pb.h"
#include "Localization.pb.h"
#include "Navigation.pb.h"
#include "Nested.pb.h"
#include "TextToSpeech.pb.h"
#include "VoiceRecognition.pb.h"
#include "test_paths.hpp"
#include "urs/schema/schema.hpp"
#include "urs_options.pb.h"

namespace urs::schema {
namespace {

namespace gp = google::protobuf;
namespace opt = urs::options;
using FD = gp::FieldDescriptor;
using ::testing::ElementsAre;
using ::testing::HasSubstr;

const gp::FileDescriptor& all_types() { return *UrsTest::Scalars::descriptor()->file(); }

const gp::Descriptor& message(const std::string& full_name) {
  const gp::Descriptor* d = gp::DescriptorPool::generated_pool()->FindMessageTypeByName(full_name);
  EXPECT_NE(d, nullptr) << full_name;
  return *d;
}

const gp::FieldDescriptor& field(const gp::Descriptor& type, const std::string& name) {
  const gp::FieldDescriptor* f = type.FindFieldByName(name);
  EXPECT_NE(f, nullptr) << type.full_name() << "." << name;
  return *f;
}

std::string idl_type(const FD& f) { return f.options().GetExtension(opt::idl_type); }

std::vector<uint32_t> dims(const FD& f) {
  std::vector<uint32_t> out;
  for (int i = 0; i < f.options().ExtensionSize(opt::array_dims); ++i) {
    out.push_back(f.options().GetExtension(opt::array_dims, i));
  }
  return out;
}

std::vector<std::string> labels(const FD& f) {
  std::vector<std::string> out;
  for (int i = 0; i < f.options().ExtensionSize(opt::case_labels); ++i) {
    out.push_back(f.options().GetExtension(opt::case_labels, i));
  }
  return out;
}

opt::MessageKind kind(const gp::Descriptor& d) { return d.options().GetExtension(opt::message_kind); }

std::vector<std::string> method_names(const gp::ServiceDescriptor& s) {
  std::vector<std::string> out;
  for (int i = 0; i < s.method_count(); ++i) out.push_back(s.method(i)->name());
  return out;
}

struct ScalarCase {
  const char* field;
  int number;
  FD::Type type;
  const char* idl;
};

TEST(Translator, ScalarsMapFieldByFieldInDeclarationOrder) {
  const gp::Descriptor& s = message("UrsTest.Scalars");
  const ScalarCase cases[] = {
      {"s", 1, FD::TYPE_INT32, "short"},
      {"l", 2, FD::TYPE_INT32, "long"},
      {"us", 3, FD::TYPE_UINT32, "unsigned short"},
      {"ul", 4, FD::TYPE_UINT32, "unsigned long"},
      {"ll", 5, FD::TYPE_INT64, "long long"},
      {"ull", 6, FD::TYPE_UINT64, "unsigned long long"},
      {"f", 7, FD::TYPE_FLOAT, "float"},
      {"d", 8, FD::TYPE_DOUBLE, "double"},
      {"b", 9, FD::TYPE_BOOL, "boolean"},
      {"c", 10, FD::TYPE_STRING, "char"},
      {"wc", 11, FD::TYPE_STRING, "wchar"},
      {"o", 12, FD::TYPE_UINT32, "octet"},
      {"str", 13, FD::TYPE_STRING, "string"},
      {"wstr", 14, FD::TYPE_STRING, "wstring"},
      {"bounded", 15, FD::TYPE_STRING, "string<8>"},
      {"ticks", 16, FD::TYPE_INT32, "long"},  // typedef long Counter: resolved
  };
  ASSERT_EQ(s.field_count(), 16);
  for (const auto& c : cases) {
    const FD& f = field(s, c.field);
    EXPECT_EQ(f.number(), c.number) << c.field;
    EXPECT_EQ(f.type(), c.type) << c.field;
    EXPECT_FALSE(f.is_repeated()) << c.field;
    EXPECT_EQ(idl_type(f), c.idl) << c.field;
    EXPECT_TRUE(dims(f).empty()) << c.field;
  }
  EXPECT_EQ(field(s, "bounded").options().GetExtension(opt::bound), 8u);
  EXPECT_FALSE(field(s, "str").options().HasExtension(opt::bound));
  EXPECT_EQ(kind(s), opt::MESSAGE_KIND_STRUCT);
  EXPECT_EQ(repository_id(s), "IDL:urs.example/UrsTest/Scalars:1.0");
}

TEST(Translator, SequencesArraysAndTheirWrappers) {
  const gp::Descriptor& c = message("UrsTest.Containers");
  const FD& blob = field(c, "blob");
  EXPECT_EQ(blob.type(), FD::TYPE_BYTES);
  EXPECT_FALSE(blob.is_repeated());
  EXPECT_EQ(idl_type(blob), "sequence<octet>");

  const FD& digest = field(c, "digest");  // octet[16]: bytes, length recorded
  EXPECT_EQ(digest.type(), FD::TYPE_BYTES);
  EXPECT_EQ(idl_type(digest), "octet");
  EXPECT_THAT(dims(digest), ElementsAre(16u));

  const FD& longs = field(c, "longs");
  EXPECT_TRUE(longs.is_repeated());
  EXPECT_EQ(longs.type(), FD::TYPE_INT32);
  EXPECT_EQ(idl_type(longs), "sequence<long>");

  const FD& nested = field(c, "nested");  // sequence<sequence<long>>: repeated wrapper
  ASSERT_EQ(nested.type(), FD::TYPE_MESSAGE);
  EXPECT_TRUE(nested.is_repeated());
  EXPECT_EQ(nested.message_type()->full_name(), "UrsTest.Containers.Seq_long");
  EXPECT_EQ(idl_type(nested), "sequence<sequence<long>>");
  const gp::Descriptor& seq_long = *nested.message_type();
  EXPECT_EQ(kind(seq_long), opt::MESSAGE_KIND_WRAPPER);
  ASSERT_EQ(seq_long.field_count(), 1);
  EXPECT_EQ(seq_long.field(0)->name(), "items");
  EXPECT_EQ(seq_long.field(0)->number(), 1);
  EXPECT_TRUE(seq_long.field(0)->is_repeated());
  EXPECT_EQ(seq_long.field(0)->type(), FD::TYPE_INT32);
  EXPECT_EQ(idl_type(*seq_long.field(0)), "sequence<long>");

  const FD& bounded = field(c, "bounded_longs");
  EXPECT_TRUE(bounded.is_repeated());
  EXPECT_EQ(idl_type(bounded), "sequence<long,5>");
  EXPECT_EQ(bounded.options().GetExtension(opt::bound), 5u);

  const FD& table = field(c, "table");  // typedef double Matrix[2][3]: flattened, row-major
  EXPECT_TRUE(table.is_repeated());
  EXPECT_EQ(table.type(), FD::TYPE_DOUBLE);
  EXPECT_EQ(idl_type(table), "double");
  EXPECT_THAT(dims(table), ElementsAre(2u, 3u));

  const FD& rows = field(c, "rows");  // sequence<long[4]>
  ASSERT_EQ(rows.type(), FD::TYPE_MESSAGE);
  EXPECT_EQ(rows.message_type()->full_name(), "UrsTest.Containers.Array4_long");
  EXPECT_EQ(idl_type(rows), "sequence<long[4]>");
  const FD& row_items = *rows.message_type()->field(0);
  EXPECT_TRUE(row_items.is_repeated());
  EXPECT_EQ(idl_type(row_items), "long");
  EXPECT_THAT(dims(row_items), ElementsAre(4u));

  const FD& grid = field(c, "grid");  // LongSeq grid[2]
  EXPECT_EQ(grid.message_type()->full_name(), "UrsTest.Containers.Seq_long");
  EXPECT_TRUE(grid.is_repeated());
  EXPECT_EQ(idl_type(grid), "sequence<long>");
  EXPECT_THAT(dims(grid), ElementsAre(2u));

  const FD& colors = field(c, "colors");
  EXPECT_TRUE(colors.is_repeated());
  EXPECT_EQ(colors.enum_type()->full_name(), "UrsTest.Color");

  const FD& points = field(c, "points");  // a type of another IDL file
  EXPECT_EQ(points.message_type()->full_name(), "UrsTest.Point");
  EXPECT_EQ(points.message_type()->file()->name(), "Shared.proto");
  EXPECT_EQ(idl_type(points), "sequence<::UrsTest::Point>");

  const FD& short_strings = field(c, "short_strings");
  EXPECT_TRUE(short_strings.is_repeated());
  EXPECT_EQ(short_strings.type(), FD::TYPE_STRING);
  EXPECT_EQ(idl_type(short_strings), "sequence<string<4>>");

  const FD& chunks = field(c, "chunks");  // sequence<sequence<octet>>: repeated bytes, no wrapper
  EXPECT_TRUE(chunks.is_repeated());
  EXPECT_EQ(chunks.type(), FD::TYPE_BYTES);
  EXPECT_EQ(c.nested_type_count(), 2);  // Seq_long and Array4_long, each once
}

TEST(Translator, RecursiveStructsAndTypesDeclaredInsideStructs) {
  const gp::Descriptor& node = message("UrsTest.Node");
  EXPECT_EQ(field(node, "children").message_type(), &node);
  EXPECT_TRUE(field(node, "children").is_repeated());

  const gp::Descriptor& outer = message("UrsTest.Outer");
  EXPECT_EQ(field(outer, "inside").message_type()->full_name(), "UrsTest.Outer_Inner");
  EXPECT_EQ(field(outer, "state").enum_type()->full_name(), "UrsTest.Outer_Mode");
  EXPECT_EQ(repository_id(message("UrsTest.Outer_Inner")), "IDL:urs.example/UrsTest/Outer/Inner:1.0");
  EXPECT_EQ(field(outer, "state").enum_type()->value(1)->name(), "OUTER_MODE_OFF");
}

TEST(Translator, EnumValuesArePrefixedWithTheEnumNameInUpperSnakeCase) {
  const gp::EnumDescriptor* color = UrsTest::Color_descriptor();
  ASSERT_EQ(color->value_count(), 3);
  const char* names[] = {"COLOR_RED", "COLOR_GREEN", "COLOR_LIGHT_BLUE"};
  const char* idl[] = {"RED", "GREEN", "LIGHT_BLUE"};
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(color->value(i)->name(), names[i]);
    EXPECT_EQ(color->value(i)->number(), i);
    EXPECT_EQ(color->value(i)->options().GetExtension(opt::idl_enumerator), idl[i]);
  }
  EXPECT_EQ(color->options().GetExtension(opt::enum_repository_id), "IDL:urs.example/UrsTest/Color:1.0");
  EXPECT_EQ(UrsTest::COLOR_LIGHT_BLUE, 2);  // C++ constant
}

TEST(Translator, UnionsBecomeADiscriminatorAndAOneof) {
  const gp::Descriptor& value = message("UrsTest.Value");
  EXPECT_EQ(kind(value), opt::MESSAGE_KIND_UNION);
  const FD& d = field(value, "discriminator");
  EXPECT_EQ(d.number(), 1);
  EXPECT_EQ(d.type(), FD::TYPE_INT32);
  EXPECT_TRUE(d.options().GetExtension(opt::discriminator));
  EXPECT_EQ(d.containing_oneof(), nullptr);
  ASSERT_EQ(value.oneof_decl_count(), 1);
  const gp::OneofDescriptor& branch = *value.oneof_decl(0);
  EXPECT_EQ(branch.name(), "branch");
  ASSERT_EQ(branch.field_count(), 5);
  EXPECT_EQ(branch.field(0)->name(), "i");
  EXPECT_EQ(branch.field(0)->number(), 2);
  EXPECT_THAT(labels(*branch.field(0)), ElementsAre("1"));
  EXPECT_EQ(branch.field(1)->name(), "s");
  EXPECT_THAT(labels(*branch.field(1)), ElementsAre("2", "3"));
  EXPECT_EQ(branch.field(2)->message_type()->full_name(), "UrsTest.Value.Seq_long");  // a oneof cannot be repeated
  EXPECT_FALSE(branch.field(2)->is_repeated());
  EXPECT_EQ(branch.field(3)->message_type()->full_name(), "UrsTest.Value.Array4_long");
  EXPECT_EQ(idl_type(*branch.field(3)), "long[4]");
  EXPECT_EQ(branch.field(4)->name(), "flag");
  EXPECT_TRUE(branch.field(4)->options().GetExtension(opt::default_case));
  EXPECT_TRUE(labels(*branch.field(4)).empty());

  EXPECT_EQ(field(message("UrsTest.Toggle"), "discriminator").type(), FD::TYPE_BOOL);
  EXPECT_THAT(labels(field(message("UrsTest.Toggle"), "on_text")), ElementsAre("TRUE"));
  EXPECT_THAT(labels(field(message("UrsTest.Toggle"), "off_code")), ElementsAre("FALSE"));
  EXPECT_EQ(idl_type(field(message("UrsTest.Letter"), "discriminator")), "char");
  EXPECT_THAT(labels(field(message("UrsTest.Letter"), "a")), ElementsAre("'a'"));
  EXPECT_EQ(field(message("UrsTest.Pick"), "discriminator").enum_type()->full_name(), "UrsTest.Color");
  EXPECT_THAT(labels(field(message("UrsTest.Pick"), "p")), ElementsAre("GREEN"));

  // The generated C++ is usable as a tagged union.
  UrsTest::Value v;
  v.set_discriminator(4);
  v.mutable_many()->add_items(7);
  EXPECT_EQ(v.branch_case(), UrsTest::Value::kMany);
}

TEST(Translator, ExceptionsAreMessagesWithTheirRepositoryId) {
  const gp::Descriptor& oops = message("UrsTest.Oops");
  EXPECT_TRUE(is_exception(oops));
  EXPECT_EQ(repository_id(oops), "IDL:urs.example/UrsTest/Oops:1.0");
  EXPECT_EQ(field(oops, "tint").enum_type()->full_name(), "UrsTest.Color");
  EXPECT_FALSE(is_exception(message("UrsTest.Scalars")));
  // Declared before the #pragma prefix, in another file: no prefix.
  EXPECT_EQ(repository_id(message("UrsTest.SharedError")), "IDL:UrsTest/SharedError:1.0");
  EXPECT_EQ(repository_id(message("UrsTest.Point")), "IDL:UrsTest/Point:1.0");
}

TEST(Translator, OperationsBecomeRequestReplyAndAnRpc) {
  const gp::ServiceDescriptor* derived = all_types().FindServiceByName("Derived");
  ASSERT_NE(derived, nullptr);
  const gp::MethodDescriptor* op = derived->FindMethodByName("op");
  ASSERT_NE(op, nullptr);
  EXPECT_EQ(op->input_type()->full_name(), "UrsTest.Derived_op_Request");
  EXPECT_EQ(op->output_type()->full_name(), "UrsTest.Derived_op_Reply");
  EXPECT_EQ(kind(*op->input_type()), opt::MESSAGE_KIND_REQUEST);
  EXPECT_EQ(kind(*op->output_type()), opt::MESSAGE_KIND_REPLY);
  EXPECT_EQ(repository_id(*op), "IDL:urs.example/UrsTest/Derived/op:1.0");
  EXPECT_THAT(raises(*op), ElementsAre("UrsTest.Oops", "UrsTest.SharedError"));
  EXPECT_FALSE(is_oneway(*op));

  // long op(in long a, out string b, inout double c)
  const gp::Descriptor& request = *op->input_type();
  ASSERT_EQ(request.field_count(), 2);
  EXPECT_EQ(request.field(0)->name(), "a");
  EXPECT_EQ(request.field(0)->number(), 1);
  EXPECT_EQ(request.field(0)->options().GetExtension(opt::param_mode), opt::PARAM_MODE_IN);
  EXPECT_EQ(request.field(0)->options().GetExtension(opt::param_position), 1u);
  EXPECT_EQ(request.field(1)->name(), "c");
  EXPECT_EQ(request.field(1)->number(), 2);
  EXPECT_EQ(request.field(1)->options().GetExtension(opt::param_mode), opt::PARAM_MODE_INOUT);
  EXPECT_EQ(request.field(1)->options().GetExtension(opt::param_position), 3u);

  const gp::Descriptor& reply = *op->output_type();
  ASSERT_EQ(reply.field_count(), 3);
  EXPECT_EQ(reply.field(0)->name(), "result");
  EXPECT_EQ(reply.field(0)->number(), 1);
  EXPECT_EQ(reply.field(0)->type(), FD::TYPE_INT32);
  EXPECT_EQ(reply.field(0)->options().GetExtension(opt::param_mode), opt::PARAM_MODE_RETURN);
  EXPECT_EQ(reply.field(1)->name(), "b");
  EXPECT_EQ(reply.field(1)->type(), FD::TYPE_STRING);
  EXPECT_EQ(reply.field(1)->options().GetExtension(opt::param_mode), opt::PARAM_MODE_OUT);
  EXPECT_EQ(reply.field(1)->options().GetExtension(opt::param_position), 2u);
  EXPECT_EQ(reply.field(2)->name(), "c");
  EXPECT_EQ(reply.field(2)->options().GetExtension(opt::param_mode), opt::PARAM_MODE_INOUT);

  // Typedefs and types declared inside the interface.
  const gp::MethodDescriptor* walk = derived->FindMethodByName("walk");
  ASSERT_NE(walk, nullptr);
  EXPECT_EQ(field(*walk->input_type(), "route").message_type()->full_name(), "UrsTest.Point");
  EXPECT_TRUE(field(*walk->input_type(), "route").is_repeated());
  EXPECT_EQ(field(*walk->output_type(), "result").message_type()->full_name(), "UrsTest.Derived_Step");
}

TEST(Translator, AttributesBecomeGetAndSetOperations) {
  const gp::ServiceDescriptor* derived = all_types().FindServiceByName("Derived");
  ASSERT_NE(derived, nullptr);
  const gp::MethodDescriptor* get = derived->FindMethodByName("_get_shade");
  const gp::MethodDescriptor* set = derived->FindMethodByName("_set_shade");
  ASSERT_NE(get, nullptr);
  ASSERT_NE(set, nullptr);
  EXPECT_EQ(get->output_type()->full_name(), "UrsTest.Derived__get_shade_Reply");
  EXPECT_EQ(get->input_type()->field_count(), 0);
  EXPECT_EQ(field(*get->output_type(), "result").enum_type()->full_name(), "UrsTest.Color");
  EXPECT_EQ(field(*set->input_type(), "shade").enum_type()->full_name(), "UrsTest.Color");
  EXPECT_EQ(set->output_type()->field_count(), 0);
  EXPECT_EQ(get->options().GetExtension(opt::attribute), "shade");
  EXPECT_EQ(repository_id(*get), "IDL:urs.example/UrsTest/Derived/shade:1.0");
  // readonly: no _set_
  const gp::ServiceDescriptor* base = all_types().FindServiceByName("Base");
  ASSERT_NE(base, nullptr);
  EXPECT_NE(base->FindMethodByName("_get_count"), nullptr);
  EXPECT_EQ(base->FindMethodByName("_set_count"), nullptr);
}

TEST(Translator, OnewayOperationsKeepAnEmptyReplyAndAreMarked) {
  const gp::MethodDescriptor* fire = all_types().FindServiceByName("Derived")->FindMethodByName("fire");
  ASSERT_NE(fire, nullptr);
  EXPECT_TRUE(is_oneway(*fire));
  EXPECT_EQ(fire->output_type()->full_name(), "UrsTest.Derived_fire_Reply");
  EXPECT_EQ(fire->output_type()->field_count(), 0);
}

TEST(Translator, InheritedOperationsReuseTheBaseMessages) {
  const gp::ServiceDescriptor* derived = all_types().FindServiceByName("Derived");
  ASSERT_NE(derived, nullptr);
  EXPECT_THAT(method_names(*derived),
              ElementsAre("ping", "_get_count", "op", "_get_shade", "_set_shade", "fire", "walk"));
  EXPECT_EQ(derived->FindMethodByName("ping")->input_type()->full_name(), "UrsTest.Base_ping_Request");
  EXPECT_EQ(repository_id(*derived), "IDL:urs.example/UrsTest/Derived:1.0");
  ASSERT_EQ(derived->options().ExtensionSize(opt::service_bases), 1);
  EXPECT_EQ(derived->options().GetExtension(opt::service_bases, 0), "IDL:urs.example/UrsTest/Base:1.0");
}

TEST(Translator, FilesImportWhatTheyUseAndNameTheirIdl) {
  const gp::FileDescriptor& file = all_types();
  EXPECT_EQ(file.package(), "UrsTest");
  EXPECT_EQ(file.syntax(), gp::FileDescriptor::SYNTAX_PROTO3);
  EXPECT_EQ(file.options().GetExtension(opt::idl_file), "AllTypes.idl");
  std::vector<std::string> imports;
  for (int i = 0; i < file.dependency_count(); ++i) imports.push_back(file.dependency(i)->name());
  EXPECT_THAT(imports, ElementsAre("Shared.proto", "urs_options.proto"));

  const std::string text = test::read_file(test::kTestProtoDir + "/AllTypes.proto");
  EXPECT_THAT(text, HasSubstr("// IDL constant UrsTest::MAX_ITEMS = 10 (constants are not part of the schema)"));
  EXPECT_THAT(text, HasSubstr("// Generated from AllTypes.idl"));
}

TEST(Translator, NestedModulesMapToANestedPackage) {
  const gp::FileDescriptor& nested = *Outer::Inner::Leaf::descriptor()->file();
  EXPECT_EQ(nested.package(), "Outer.Inner");
  ASSERT_EQ(nested.service_count(), 1);
  EXPECT_EQ(nested.service(0)->full_name(), "Outer.Inner.Tree");
  Outer::Inner::Tree_get_Reply reply;
  reply.mutable_result()->set_v(3);
  EXPECT_EQ(repository_id(*nested.service(0)), "IDL:Outer/Inner/Tree:1.0");
}

TEST(Translator, DiagnosticSchemaIsTheContractOthersCodeAgainst) {
  const gp::ServiceDescriptor* diag =
      URS::Diagnostic_echo_Request::descriptor()->file()->FindServiceByName("Diagnostic");
  ASSERT_NE(diag, nullptr);
  EXPECT_EQ(diag->full_name(), "URS.Diagnostic");
  EXPECT_THAT(method_names(*diag), ElementsAre("echo", "add", "sleep", "blob", "checksum", "fail", "notify"));
  EXPECT_EQ(repository_id(*diag), "IDL:URS/Diagnostic:1.0");
  EXPECT_THAT(raises(*diag->FindMethodByName("fail")), ElementsAre("URS.Failure"));
  EXPECT_TRUE(is_oneway(*diag->FindMethodByName("notify")));
  EXPECT_FALSE(is_oneway(*diag->FindMethodByName("echo")));

  URS::Diagnostic_blob_Reply blob;
  blob.set_result(std::string("\x00\x01", 2));  // sequence<octet> -> bytes
  URS::Diagnostic_checksum_Reply sum;
  sum.set_result(UINT64_MAX);  // unsigned long long -> uint64
  URS::Diagnostic_sleep_Request sleep;
  sleep.set_ms(5u);  // unsigned long -> uint32
  URS::Failure failure;
  failure.set_reason("r");
  failure.set_code(-3);
  EXPECT_EQ(repository_id(*URS::Failure::descriptor()), "IDL:URS/Failure:1.0");
}

TEST(Translator, UrcInterfacesHaveTheServicesOfThePapers) {
  auto methods = [](const gp::Descriptor* any_message, const std::string& service) {
    const gp::ServiceDescriptor* s = any_message->file()->FindServiceByName(service);
    EXPECT_NE(s, nullptr) << service;
    return s == nullptr ? std::vector<std::string>{} : method_names(*s);
  };
  EXPECT_THAT(methods(URC::Pose2D::descriptor(), "Navigation"),
              ElementsAre("moveTo", "getPosition", "stop", "setSpeed", "_get_speed", "_get_max_speed", "_get_state"));
  EXPECT_THAT(methods(URC::PoseWithCovariance::descriptor(), "Localization"), ElementsAre("getPose", "_get_rate"));
  EXPECT_THAT(methods(URC::AudioInfo::descriptor(), "TextToSpeech"),
              ElementsAre("speak", "getAvailableVoices", "setVoice", "cancelAll", "_get_voice"));
  EXPECT_THAT(methods(URC::RecognitionResult::descriptor(), "VoiceRecognition"),
              ElementsAre("playBytes", "playFile", "startStream", "feedStream", "finishStream", "cancelAll"));
  EXPECT_THAT(methods(URC::Marker::descriptor(), "ImageRecognition"),
              ElementsAre("openCamera", "closeCamera", "captureImage", "getImageFormat", "recognize"));

  URC::Navigation_moveTo_Request move;  // metres
  move.set_x(1.5);
  move.set_y(3.0);
  URC::Navigation_setSpeed_Request speed;  // mm/s
  speed.set_speed(500);
  EXPECT_THAT(raises(*URC::Navigation_moveTo_Request::descriptor()
                          ->file()
                          ->FindServiceByName("Navigation")
                          ->FindMethodByName("moveTo")),
              ElementsAre("URC.InvalidTarget", "URC.NotReady"));
  const FD& covariance = field(*URC::PoseWithCovariance::descriptor(), "covariance");
  EXPECT_THAT(dims(covariance), ElementsAre(3u, 3u));
  const FD& corners = field(*URC::Marker::descriptor(), "corners");
  EXPECT_THAT(dims(corners), ElementsAre(4u));
  EXPECT_EQ(URC::IMAGE_ENCODING_RAW_RGB8, 0);
  EXPECT_EQ(URC::NAVIGATION_STATE_ARRIVED, 2);
}

TEST(Signature, OperationsAndAttributesReadAsIdlDeclaresThem) {
  const gp::ServiceDescriptor* derived = all_types().FindServiceByName("Derived");
  const gp::ServiceDescriptor* base = all_types().FindServiceByName("Base");
  ASSERT_NE(derived, nullptr);
  ASSERT_NE(base, nullptr);
  auto signature = [&](const gp::ServiceDescriptor* s, const char* name) {
    const gp::MethodDescriptor* m = s->FindMethodByName(name);
    return m == nullptr ? std::string("<no ") + name + ">" : idl_signature(*m);
  };
  EXPECT_EQ(signature(derived, "op"),
            "long op(in long a, out string b, inout double c) raises (UrsTest::Oops, UrsTest::SharedError)");
  EXPECT_EQ(signature(derived, "fire"), "oneway void fire(in string what)");
  EXPECT_EQ(signature(derived, "walk"),
            "UrsTest::Derived::Step walk(in sequence<UrsTest::Point> route, in UrsTest::Value how)");
  EXPECT_EQ(signature(derived, "_get_shade"), "attribute UrsTest::Color shade");
  EXPECT_EQ(signature(derived, "_set_shade"), "");  // the attribute line covers it
  EXPECT_EQ(signature(base, "_get_count"), "readonly attribute long count");
  EXPECT_EQ(signature(base, "ping"), "void ping()");
}

}  // namespace
}  // namespace urs::schema
