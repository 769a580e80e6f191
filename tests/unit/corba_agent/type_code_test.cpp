// TypeCodes built from descriptors are equivalent to the ones omniidl generates from the IDL, with
// the same repository IDs, so DSI arguments, results and exceptions look exactly as stubs expect.

#include <gtest/gtest.h>

#include "samples.hpp"
#include "stub_side.hpp"
#include "urs/corba_agent/type_codes.hpp"

namespace urs::test {
namespace {

TEST(TypeCodes, EveryTypeIsEquivalentToOmniidlsWithItsRepositoryId) {
  corba_agent::TypeCodes type_codes(test_orb());
  for (const auto& sample : samples()) {
    SCOPED_TRACE(sample.idl_name);
    CORBA::TypeCode_var built = type_codes.message(*sample.type);
    CORBA::TypeCode_var expected = stub_type_code(sample.idl_name);
    ASSERT_FALSE(CORBA::is_nil(expected));
    EXPECT_TRUE(built->equivalent(expected));
    EXPECT_STREQ(built->id(), expected->id());
    EXPECT_STREQ(built->name(), expected->name());
  }
}

TEST(TypeCodes, ArraysSequencesAndBoundsHaveTheirShapes) {
  corba_agent::TypeCodes type_codes(test_orb());
  const auto* containers = UrsTest::Containers::descriptor();
  CORBA::TypeCode_var table = type_codes.field(*containers->FindFieldByName("table"));  // double[2][3]
  ASSERT_EQ(table->kind(), CORBA::tk_array);
  EXPECT_EQ(table->length(), 2u);
  CORBA::TypeCode_var row = table->content_type();
  EXPECT_EQ(row->length(), 3u);
  CORBA::TypeCode_var bounded = type_codes.field(*containers->FindFieldByName("bounded_longs"));
  EXPECT_EQ(bounded->kind(), CORBA::tk_sequence);
  EXPECT_EQ(bounded->length(), 5u);
  CORBA::TypeCode_var rows = type_codes.field(*containers->FindFieldByName("rows"));  // sequence<long[4]>
  CORBA::TypeCode_var element = rows->content_type();
  EXPECT_EQ(element->kind(), CORBA::tk_array);
  EXPECT_EQ(element->length(), 4u);
  CORBA::TypeCode_var name = type_codes.field(*UrsTest::Scalars::descriptor()->FindFieldByName("bounded"));
  EXPECT_EQ(name->kind(), CORBA::tk_string);
  EXPECT_EQ(name->length(), 8u);
}

TEST(TypeCodes, MessagesThatAreNotIdlTypesAreRefused) {
  corba_agent::TypeCodes type_codes(test_orb());
  EXPECT_THROW(CORBA::TypeCode_var(type_codes.message(*URS::Diagnostic_echo_Request::descriptor())),
               std::invalid_argument);
}

}  // namespace
}  // namespace urs::test
