// load_idl(): an IDL file translated at run time, without a rebuild.
#include <gmock/gmock.h>
#include <google/protobuf/descriptor.pb.h>
#include <google/protobuf/util/message_differencer.h>
#include <gtest/gtest.h>

#include <cstdlib>

#include "AllTypes.pb.h"
#include "test_paths.hpp"
#include "urs/schema/schema.hpp"

namespace urs::schema {
namespace {

namespace gp = google::protobuf;
using ::testing::ElementsAre;
using ::testing::HasSubstr;

// Sets an environment variable for one test, restoring it afterwards.
class ScopedEnv {
 public:
  ScopedEnv(const char* name, const std::string& value) : name_(name) {
    if (const char* old = std::getenv(name)) old_ = old;
    ::setenv(name, value.c_str(), 1);
  }
  ~ScopedEnv() {
    if (old_.empty())
      ::unsetenv(name_);
    else
      ::setenv(name_, old_.c_str(), 1);
  }
  ScopedEnv(const ScopedEnv&) = delete;
  ScopedEnv& operator=(const ScopedEnv&) = delete;

 private:
  const char* name_;
  std::string old_;
};

TEST(LoadIdl, AnIdlNoBinaryWasBuiltWithYieldsAUsableService) {
  const IdlLoad load = load_idl(test::kTestIdlDir + "/runtime/Thermostat.idl", {test::kTestIdlDir});
  ASSERT_TRUE(load.ok()) << load.error;
  EXPECT_THAT(load.services, ElementsAre("UrsTest.Thermostat"));

  SchemaPool pool;
  ASSERT_EQ(pool.add_descriptor_set(load.descriptor_set), "");
  const gp::ServiceDescriptor* thermostat = pool.find_service("UrsTest.Thermostat");
  ASSERT_NE(thermostat, nullptr);
  EXPECT_EQ(repository_id(*thermostat), "IDL:UrsTest/Thermostat:1.0");
  const gp::MethodDescriptor* set_target = thermostat->FindMethodByName("setTarget");
  ASSERT_NE(set_target, nullptr);
  EXPECT_THAT(raises(*set_target), ElementsAre("UrsTest.SharedError"));
  EXPECT_NE(pool.find_message("UrsTest.SharedError"), nullptr);  // the #included file came along

  auto reply = pool.new_message(*thermostat->FindMethodByName("read")->output_type());
  const std::string json = R"({"result":{"celsius":21.5,"where":{"x":1,"y":2},"mode":"HEAT_MODE_ECO"}})";
  ASSERT_EQ(json_to_message(json, *reply), "");
  std::string out;
  ASSERT_EQ(message_to_json(*reply, out), "");
  EXPECT_EQ(out, json);
}

TEST(LoadIdl, RunTimeTranslationEqualsTheBuildTranslation) {
  const IdlLoad load = load_idl(test::kTestIdlDir + "/AllTypes.idl");
  ASSERT_TRUE(load.ok()) << load.error;
  EXPECT_THAT(load.services, ElementsAre("UrsTest.Base", "UrsTest.Derived"));
  gp::FileDescriptorSet set;
  ASSERT_TRUE(set.ParseFromString(load.descriptor_set));
  std::vector<std::string> names;
  for (const auto& file : set.file()) names.push_back(file.name());
  EXPECT_THAT(names,
              ElementsAre("google/protobuf/descriptor.proto", "urs_options.proto", "Shared.proto", "AllTypes.proto"));

  gp::FileDescriptorProto built;
  const gp::FileDescriptor* compiled = UrsTest::Scalars::descriptor()->file();
  compiled->CopyTo(&built);
  compiled->CopyJsonNameTo(&built);
  std::string difference;
  gp::util::MessageDifferencer differencer;
  differencer.ReportDifferencesToString(&difference);
  EXPECT_TRUE(differencer.Compare(built, set.file(3))) << difference;
}

TEST(LoadIdl, ItsDescriptorSetJoinsAPoolHoldingTheBuildSchemas) {
  SchemaPool pool;
  ASSERT_EQ(pool.add_descriptor_set(test::read_file(test::kIdlDescriptorSet)), "");
  const IdlLoad load = load_idl(test::kTestIdlDir + "/runtime/Thermostat.idl", {test::kTestIdlDir});
  ASSERT_TRUE(load.ok()) << load.error;
  EXPECT_EQ(pool.add_descriptor_set(load.descriptor_set), "");  // urs_options.proto: same content
  EXPECT_NE(pool.find_service("UrsTest.Thermostat"), nullptr);
  EXPECT_NE(pool.find_service("URS.Diagnostic"), nullptr);
}

TEST(LoadIdl, ABrokenIdlGivesOmniidlsErrorWithFileAndLine) {
  const std::string path = test::kTestIdlDir + "/Broken.idl";
  const IdlLoad load = load_idl(path);
  EXPECT_FALSE(load.ok());
  EXPECT_TRUE(load.descriptor_set.empty());
  EXPECT_THAT(load.error, HasSubstr("omniidl could not translate '" + path + "' (exit status 1;"));
  EXPECT_THAT(load.error, HasSubstr(path + ":3: Syntax error"));
}

TEST(LoadIdl, AMissingFileIsReported) {
  const IdlLoad load = load_idl(test::kTestIdlDir + "/NoSuchFile.idl");
  EXPECT_EQ(load.error, "IDL file '" + test::kTestIdlDir + "/NoSuchFile.idl' does not exist or is not a regular file");
}

TEST(LoadIdl, AnUnfindableIncludeIsOmniidlsError) {
  const IdlLoad load = load_idl(test::kTestIdlDir + "/runtime/Thermostat.idl");  // no include dir for Shared.idl
  EXPECT_FALSE(load.ok());
  EXPECT_THAT(load.error, HasSubstr("Shared.idl"));
}

TEST(LoadIdl, TheBackEndFolderCanBeOverridden) {
  ScopedEnv env("URS_OMNIIDL_BACKEND_DIR", test::kTestIdlDir);  // holds no back-end
  const IdlLoad load = load_idl(test::kTestIdlDir + "/Shared.idl");
  EXPECT_FALSE(load.ok());
  EXPECT_THAT(load.error, HasSubstr("back-end folder " + test::kTestIdlDir));
  EXPECT_THAT(load.error, HasSubstr("Could not import back-end 'planet_proto'"));
}

TEST(LoadIdl, AMissingOmniidlIsReportedWithTheFix) {
  ScopedEnv env("URS_OMNIIDL", "/nonexistent/omniidl");
  const IdlLoad load = load_idl(test::kTestIdlDir + "/Shared.idl");
  EXPECT_EQ(load.error,
            "cannot run '/nonexistent/omniidl': No such file or directory (install the Debian package omniidl, or "
            "set URS_OMNIIDL to its path)");
}

TEST(LoadIdl, PathsTheShellWouldMangleAreRefused) {
  const IdlLoad load = load_idl(test::kTestIdlDir + "/Shared.idl", {"/tmp/$HOME"});
  EXPECT_EQ(load.error, "path '/tmp/$HOME' contains one of \" $ ` \\, which omniidl cannot pass to its preprocessor");
}

}  // namespace
}  // namespace urs::schema
