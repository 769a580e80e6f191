// SchemaPool and descriptor_set_for(): descriptions received at run time.
#include <gmock/gmock.h>
#include <google/protobuf/descriptor.pb.h>
#include <gtest/gtest.h>

#include <atomic>
#include <thread>

#include "Diagnostic.pb.h"
#include "test_paths.hpp"
#include "urs/schema/schema.hpp"

namespace urs::schema {
namespace {

namespace gp = google::protobuf;
using ::testing::ElementsAre;
using ::testing::HasSubstr;

gp::FileDescriptorSet parse_set(const std::string& bytes) {
  gp::FileDescriptorSet set;
  EXPECT_TRUE(set.ParseFromString(bytes));
  return set;
}

std::vector<std::string> file_names(const std::string& bytes) {
  const gp::FileDescriptorSet set = parse_set(bytes);
  std::vector<std::string> out;
  for (const auto& file : set.file()) out.push_back(file.name());
  return out;
}

// The files of `bytes` whose name is in `keep`, in order.
std::string subset(const std::string& bytes, const std::vector<std::string>& keep) {
  gp::FileDescriptorSet in = parse_set(bytes), out;
  for (const auto& file : in.file()) {
    if (std::find(keep.begin(), keep.end(), file.name()) != keep.end()) *out.add_file() = file;
  }
  return out.SerializeAsString();
}

TEST(DescriptorSet, HoldsTheFileAndItsImportsDependenciesFirst) {
  const std::string set = descriptor_set_for(*URS::Diagnostic_echo_Request::descriptor()->file());
  EXPECT_THAT(file_names(set),
              ElementsAre("google/protobuf/descriptor.proto", "urs_options.proto", "Diagnostic.proto"));
  const gp::FileDescriptorSet parsed = parse_set(set);
  EXPECT_FALSE(parsed.file(2).has_source_code_info());
  EXPECT_EQ(parsed.file(2).package(), "URS");
}

TEST(SchemaPool, LoadsTheBuildDescriptorSetOfUrsIdl) {
  SchemaPool pool;
  ASSERT_EQ(pool.add_descriptor_set(test::read_file(test::kIdlDescriptorSet)), "");
  const gp::ServiceDescriptor* diag = pool.find_service("URS.Diagnostic");
  ASSERT_NE(diag, nullptr);
  EXPECT_NE(diag, URS::Diagnostic_echo_Request::descriptor()->file()->FindServiceByName("Diagnostic"));  // own copy
  EXPECT_EQ(pool.find_method("URS.Diagnostic.add")->input_type(), pool.find_message("URS.Diagnostic_add_Request"));
  EXPECT_NE(pool.find_enum("URC.ImageEncoding"), nullptr);
  EXPECT_EQ(pool.find_service("URS.Nope"), nullptr);
  EXPECT_EQ(pool.find_message("URS.Nope"), nullptr);
  EXPECT_THAT(pool.service_names(), ElementsAre("URC.ImageRecognition", "URC.Localization", "URC.Navigation",
                                                "URC.TextToSpeech", "URC.VoiceRecognition", "URS.Diagnostic"));
  // Options survive the trip through bytes and a foreign pool.
  EXPECT_THAT(raises(*diag->FindMethodByName("fail")), ElementsAre("URS.Failure"));
  EXPECT_TRUE(is_oneway(*diag->FindMethodByName("notify")));
  EXPECT_EQ(repository_id(*diag), "IDL:URS/Diagnostic:1.0");
  EXPECT_TRUE(is_exception(*pool.find_message("URS.Failure")));
}

TEST(SchemaPool, SkipsFilesAlreadyPresentWithTheSameContent) {
  SchemaPool pool;
  const std::string set = test::read_file(test::kIdlDescriptorSet);
  ASSERT_EQ(pool.add_descriptor_set(set), "");
  const gp::Descriptor* before = pool.find_message("URC.Pose2D");
  EXPECT_EQ(pool.add_descriptor_set(set), "");
  // The same files produced by FileDescriptor::CopyTo (another sender) rather than protoc.
  EXPECT_EQ(pool.add_descriptor_set(descriptor_set_for(*URS::Diagnostic_echo_Request::descriptor()->file())), "");
  EXPECT_EQ(pool.find_message("URC.Pose2D"), before);
}

TEST(SchemaPool, RefusesAnotherVersionOfALoadedFileNamingIt) {
  SchemaPool pool;
  const std::string set = test::read_file(test::kIdlDescriptorSet);
  ASSERT_EQ(pool.add_descriptor_set(set), "");
  gp::FileDescriptorSet changed = parse_set(set);
  for (auto& file : *changed.mutable_file()) {
    if (file.name() == "Diagnostic.proto") file.mutable_message_type(0)->mutable_field(0)->set_name("renamed");
  }
  EXPECT_EQ(pool.add_descriptor_set(changed.SerializeAsString()),
            "file 'Diagnostic.proto' is already loaded with a different content (another version of the "
            "interface?); keep one version per pool");
}

TEST(SchemaPool, ReportsMissingImportsNamingTheFiles) {
  SchemaPool pool;
  const std::string error =
      pool.add_descriptor_set(subset(test::read_file(test::kIdlDescriptorSet),
                                     {"google/protobuf/descriptor.proto", "urs_options.proto", "Navigation.proto"}));
  EXPECT_THAT(error, HasSubstr("cannot load file 'Navigation.proto'"));
  EXPECT_THAT(error, HasSubstr("URCTypes.proto"));
  // All or nothing: nothing of the set was added.
  EXPECT_EQ(pool.find_enum("urs.options.MessageKind"), nullptr);
}

TEST(SchemaPool, ReportsUnresolvedTypesNamingTheElement) {
  gp::FileDescriptorSet set;
  gp::FileDescriptorProto* file = set.add_file();
  file->set_name("Broken.proto");
  file->set_package("broken");
  file->set_syntax("proto3");
  gp::DescriptorProto* message = file->add_message_type();
  message->set_name("M");
  gp::FieldDescriptorProto* f = message->add_field();
  f->set_name("x");
  f->set_number(1);
  f->set_label(gp::FieldDescriptorProto::LABEL_OPTIONAL);
  f->set_type_name(".broken.Missing");
  SchemaPool pool;
  EXPECT_EQ(pool.add_descriptor_set(set.SerializeAsString()),
            "cannot load file 'Broken.proto': Broken.proto: broken.M.x: \".broken.Missing\" is not defined.");
  EXPECT_EQ(pool.find_message("broken.M"), nullptr);
}

TEST(SchemaPool, RefusesANameAnotherLoadedFileDefines) {
  SchemaPool pool;
  ASSERT_EQ(pool.add_descriptor_set(test::read_file(test::kIdlDescriptorSet)), "");
  gp::FileDescriptorSet set;
  gp::FileDescriptorProto* file = set.add_file();
  file->set_name("Impostor.proto");
  file->set_package("URS");
  file->set_syntax("proto3");
  file->add_message_type()->set_name("Failure");
  EXPECT_EQ(pool.add_descriptor_set(set.SerializeAsString()),
            "cannot load file 'Impostor.proto': it defines 'URS.Failure', which loaded file 'Diagnostic.proto' "
            "already defines; rename one of them");
}

TEST(SchemaPool, RefusesBytesThatAreNotADescriptorSet) {
  SchemaPool pool;
  EXPECT_EQ(pool.add_descriptor_set(std::string("\xff\xff\xff", 3)),
            "the 3 bytes received are not a serialized google.protobuf.FileDescriptorSet");
  EXPECT_EQ(pool.add_descriptor_set(""), "");  // an empty set is a valid, empty set
}

TEST(SchemaPool, NewMessageWorksForPoolAndGeneratedDescriptors) {
  SchemaPool pool;
  ASSERT_EQ(pool.add_descriptor_set(test::read_file(test::kIdlDescriptorSet)), "");
  auto dynamic = pool.new_message(*pool.find_message("URS.Diagnostic_echo_Request"));
  ASSERT_NE(dynamic, nullptr);
  EXPECT_EQ(dynamic->GetDescriptor()->full_name(), "URS.Diagnostic_echo_Request");
  auto compiled = pool.new_message(*URS::Diagnostic_echo_Request::descriptor());
  ASSERT_NE(compiled, nullptr);
  EXPECT_EQ(compiled->GetDescriptor(), URS::Diagnostic_echo_Request::descriptor());
}

TEST(SchemaPool, LookupsRunWhileAnotherThreadAdds) {
  SchemaPool pool;
  const std::string set = test::read_file(test::kIdlDescriptorSet);
  std::atomic<bool> stop{false};
  std::atomic<long> lookups{0};
  std::thread reader([&] {
    while (!stop.load()) {
      if (const gp::Descriptor* d = pool.find_message("URS.Diagnostic_add_Request")) {
        auto message = pool.new_message(*d);
        std::string json;
        EXPECT_EQ(message_to_json(*message, json), "");
      }
      lookups.fetch_add(1);
    }
  });
  for (int i = 0; i < 20; ++i) EXPECT_EQ(pool.add_descriptor_set(set), "");
  while (lookups.load() < 100) std::this_thread::yield();
  stop = true;
  reader.join();
  EXPECT_NE(pool.find_service("URS.Diagnostic"), nullptr);
}

}  // namespace
}  // namespace urs::schema
