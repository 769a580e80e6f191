#pragma once
// What omniidl's stubs make of CDR, for tests that cannot include them next to the Protobuf
// classes of the same IDL (see CMakeLists.txt). Types are named as in IDL: "UrsTest::Scalars".

#include <omniORB4/CORBA.h>

#include <string>

namespace urs::test {

// The stubs read `cdr` (native byte order, from offset 0) as one value of `type` and write it
// back; the bytes written. Throws std::invalid_argument for an unknown type, std::length_error if
// bytes remain after the value, and whatever the stubs throw (CORBA::MARSHAL for short input).
std::string stub_echo(const std::string& type, const std::string& cdr);

// The process's ORB, initialised on first use: streams take their code sets from it.
CORBA::ORB_ptr test_orb();

// The TypeCode omniidl generated for `type`; nil for an unknown type.
CORBA::TypeCode_ptr stub_type_code(const std::string& type);

}  // namespace urs::test
