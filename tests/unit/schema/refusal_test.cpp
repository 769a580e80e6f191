// Constructs the Planet mapping refuses: omniidl exits non-zero and every error names the IDL
// file, the line and the construct. Run through load_idl(), which runs omniidl as the build does.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "test_paths.hpp"
#include "urs/schema/idl.hpp"

namespace urs::schema {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;

struct Refusal {
  const char* file;
  int line;
  const char* message;  // after "<path>:<line>: error: "
};

void PrintTo(const Refusal& r, std::ostream* out) { *out << r.file << ":" << r.line; }

class Refused : public ::testing::TestWithParam<Refusal> {};

TEST_P(Refused, OmniidlFailsNamingFileLineAndConstruct) {
  const Refusal& r = GetParam();
  const std::string path = test::kTestIdlDir + "/refused/" + r.file;
  const IdlLoad load = load_idl(path);
  EXPECT_FALSE(load.ok());
  EXPECT_TRUE(load.descriptor_set.empty());
  EXPECT_THAT(load.error, HasSubstr("(exit status 1;"));
  EXPECT_THAT(load.error, HasSubstr(path + ":" + std::to_string(r.line) + ": error: " + r.message));
  EXPECT_THAT(load.error, HasSubstr("no .proto written"));
}

INSTANTIATE_TEST_SUITE_P(
    Translator, Refused,
    ::testing::Values(
        Refusal{"Any.idl", 4,
                "parameter 'value' of operation 'R::I::put': 'any' is not supported by the Planet mapping: an any "
                "carries its TypeCode at run time but a Planet schema is static; use a union, a struct or "
                "sequence<octet>"},
        Refusal{"ObjectRef.idl", 5,
                "parameter 'other' of operation 'R::I::link': object reference 'R::Peer' is not supported by the "
                "Planet mapping: object references cannot cross Planet (no remote object identity); pass a name or "
                "an ID instead"},
        Refusal{"ValueType.idl", 3, "valuetype 'R::V' is not supported by the Planet mapping: valuetypes"},
        Refusal{"Fixed.idl", 4,
                "member 'amount' of struct 'R::Money': 'fixed<5,2>' is not supported by the Planet mapping: Protobuf "
                "has no decimal fixed-point type"},
        Refusal{"Native.idl", 3, "native 'R::Handle' is not supported by the Planet mapping"},
        Refusal{"LongDouble.idl", 3,
                "member 'value' of struct 'R::Precise': 'long double' is not supported by the Planet mapping"},
        Refusal{"LocalInterface.idl", 3,
                "local interface 'R::L' is not supported by the Planet mapping: local interfaces cannot be invoked "
                "remotely"},
        Refusal{"TwoModules.idl", 3,
                "struct 'B::Y' is in module 'B' but earlier declarations of TwoModules.idl are in module 'A'"},
        Refusal{"ResultClash.idl", 4,
                "parameter 'result' of operation 'R::I::op': an out/inout parameter named 'result' clashes with the "
                "field carrying the return value; rename it"},
        Refusal{"NameClash.idl", 4,
                "struct 'R::I_op_Request' maps to the Protobuf name 'R.I_op_Request', already used by the request of "
                "operation 'R::I::op'"}),
    [](const ::testing::TestParamInfo<Refusal>& info) {
      std::string name = info.param.file;
      return name.substr(0, name.find('.'));
    });

TEST(Translator, ReportsEveryErrorOfAFileNotOnlyTheFirst) {
  const std::string path = test::kTestIdlDir + "/refused/Several.idl";
  const IdlLoad load = load_idl(path);
  EXPECT_THAT(load.error, HasSubstr(path + ":4: error: member 'first' of struct 'R::S': 'any' is not supported"));
  EXPECT_THAT(load.error,
              HasSubstr(path + ":5: error: member 'second' of struct 'R::S': 'fixed<3,1>' is not supported"));
  EXPECT_THAT(load.error, HasSubstr("2 error(s)"));
}

TEST(Translator, SupportedFilesProduceNoErrorOutput) {
  const IdlLoad load = load_idl(test::kTestIdlDir + "/AllTypes.idl");
  EXPECT_TRUE(load.ok()) << load.error;
  EXPECT_THAT(load.error, Not(HasSubstr("error")));
}

}  // namespace
}  // namespace urs::schema
