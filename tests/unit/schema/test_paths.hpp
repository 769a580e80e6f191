#pragma once
// Paths handed in by tests/unit/schema/CMakeLists.txt, and small helpers shared by the tests.
#include <fstream>
#include <sstream>
#include <string>

namespace urs::schema::test {

inline const std::string kIdlDescriptorSet = URS_IDL_DESCRIPTOR_SET;    // urs::idl's .desc
inline const std::string kTestDescriptorSet = URS_TEST_DESCRIPTOR_SET;  // schema_test_idl's .desc
inline const std::string kTestProtoDir = URS_TEST_PROTO_DIR;            // its generated .proto files
inline const std::string kTestIdlDir = URS_TEST_IDL_DIR;                // tests/unit/schema/idl

inline std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream out;
  out << in.rdbuf();
  return out.str();
}

}  // namespace urs::schema::test
