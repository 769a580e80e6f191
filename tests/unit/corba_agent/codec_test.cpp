// CdrCodec against omniORB's stubs of the same IDL: every IDL type the URC, URS and test IDL use
// goes Protobuf -> CDR (codec) -> stubs -> CDR (stubs) -> Protobuf (codec) unchanged; values IDL cannot
// hold are refused with the field's path; CDR that is not a value is refused when read.

#include <google/protobuf/util/message_differencer.h>
#include <gtest/gtest.h>

#include "samples.hpp"
#include "stub_side.hpp"
#include "urs/corba_agent/cdr_codec.hpp"

namespace urs::test {
namespace {

using corba_agent::CdrCodec;
using corba_agent::ConversionError;
using google::protobuf::Message;

std::string bytes_of(const cdrMemoryStream& stream) {
  return std::string(static_cast<const char*>(stream.bufPtr()), stream.bufSize());
}

class Codec : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { test_orb(); }

  std::string write(const Message& message) const {
    cdrMemoryStream stream;
    codec_.write(stream, message);
    return bytes_of(stream);
  }
  std::unique_ptr<Message> read(const google::protobuf::Descriptor& type, const std::string& cdr) const {
    cdrMemoryStream stream;
    stream.put_octet_array(reinterpret_cast<const CORBA::Octet*>(cdr.data()), static_cast<int>(cdr.size()));
    auto message = parse(type, "");
    codec_.read(stream, *message);
    EXPECT_FALSE(stream.checkInputOverrun(1, 1)) << "bytes remain after " << type.full_name();
    return message;
  }
  // The error writing `text` as a `type` gives; empty if it is written.
  std::string write_error(const google::protobuf::Descriptor& type, const std::string& text) const {
    try {
      write(*parse(type, text));
      return "";
    } catch (const ConversionError& e) {
      return e.what();
    }
  }

  CdrCodec codec_{sample_types()};
};

TEST_F(Codec, TheStubsReadWhatItWritesAndItReadsWhatTheyWrite) {
  for (const auto& sample : samples()) {
    SCOPED_TRACE(sample.idl_name + " " + sample.text);
    const auto original = parse(*sample.type, sample.text);
    const std::string cdr = write(*original);
    // The stubs consume exactly the value (alignment padding is left unset by omniORB's memory
    // streams, so bytes are compared through the values, not directly).
    const std::string echoed = stub_echo(sample.idl_name, cdr);
    EXPECT_EQ(echoed.size(), cdr.size());
    const auto back = read(*sample.type, echoed);
    EXPECT_TRUE(google::protobuf::util::MessageDifferencer::Equals(*original, *back)) << back->DebugString();
  }
}

TEST_F(Codec, FieldsAreWrittenAsTheirIdlTypesInDeclarationOrder) {
  // Step {Point at; unsigned long index;}: two doubles, then the unsigned long.
  const auto step = parse(*UrsTest::Derived_Step::descriptor(), "at { x: 1 y: 2 } index: 7");
  const std::string cdr = write(*step);
  ASSERT_EQ(cdr.size(), 20u);  // two doubles, one unsigned long
  EXPECT_EQ(cdr.substr(16), std::string("\x07\x00\x00\x00", 4));
  // sequence<octet>: the length then the bytes, copied as they are.
  const auto image = parse(*URC::Image::descriptor(), R"(data: "\000\377")");
  const std::string image_cdr = write(*image);
  EXPECT_EQ(image_cdr.substr(image_cdr.size() - 6), std::string("\x02\x00\x00\x00\x00\xff", 6));
}

TEST_F(Codec, ValuesIdlCannotHoldAreRefusedNamingTheField) {
  const auto* scalars = UrsTest::Scalars::descriptor();
  EXPECT_EQ(write_error(*scalars, "s: 40000"), "UrsTest.Scalars.s: short value 40000 is out of range -32768..32767");
  EXPECT_EQ(write_error(*scalars, "us: 70000 c: \"a\" wc: \"b\""),
            "UrsTest.Scalars.us: unsigned short value 70000 is out of range 0..65535");
  EXPECT_EQ(write_error(*scalars, "o: 256 c: \"a\" wc: \"b\""),
            "UrsTest.Scalars.o: octet value 256 is out of range 0..255");
  EXPECT_EQ(write_error(*scalars, "c: \"ab\""),
            "UrsTest.Scalars.c: a char must be exactly one character of ISO 8859-1, not 'ab'");
  EXPECT_EQ(write_error(*scalars, "c: \"€\""),
            "UrsTest.Scalars.c: a char must be exactly one character of ISO 8859-1, not '€'");
  EXPECT_EQ(write_error(*scalars, "c: \"a\" wc: \"\""),
            "UrsTest.Scalars.wc: a wchar must be exactly one character, not ''");
  EXPECT_EQ(write_error(*scalars, R"(c: "a" wc: "b" str: "a\000b")"),
            "UrsTest.Scalars.str: a CORBA string cannot hold a NUL character");
  EXPECT_EQ(write_error(*scalars, R"(c: "a" wc: "b" bounded: "123456789")"),
            "UrsTest.Scalars.bounded: a string of 9 is over the bound of 8");

  const auto* containers = UrsTest::Containers::descriptor();
  const std::string arrays = R"(digest: "0123456789abcdef" table: [1, 2, 3, 4, 5, 6] grid { } grid { } )";
  EXPECT_EQ(write_error(*containers, arrays), "");
  EXPECT_EQ(write_error(*containers, arrays + "bounded_longs: [1, 2, 3, 4, 5, 6]"),
            "UrsTest.Containers.bounded_longs: a sequence length of 6 is over the bound of 5");
  EXPECT_EQ(write_error(*containers, R"(digest: "0123456789abcde")"),
            "UrsTest.Containers.digest: holds 15 octets; the array has 16");
  EXPECT_EQ(write_error(*containers, R"(digest: "0123456789abcdef" table: [1, 2, 3, 4, 5])"),
            "UrsTest.Containers.table: holds 5 elements; the array has 6");
  EXPECT_EQ(write_error(*containers, arrays + R"(short_strings: ["abcd", "abcde"])"),
            "UrsTest.Containers.short_strings[1]: a string of 5 is over the bound of 4");
  EXPECT_EQ(write_error(*containers, arrays + "rows { items: [1, 2, 3] }"),
            "UrsTest.Containers.rows[0]: holds 3 elements; the array has 4");
  EXPECT_EQ(write_error(*URC::Marker::descriptor(), "corners { }"),
            "URC.Marker.corners: holds 1 elements; the array has 4");

  auto colors = parse(*containers, arrays);
  colors->GetReflection()->AddEnumValue(colors.get(), containers->FindFieldByName("colors"), 7);
  try {
    write(*colors);
    ADD_FAILURE() << "an undeclared enum value was written";
  } catch (const ConversionError& e) {
    EXPECT_STREQ(e.what(), "UrsTest.Containers.colors[0]: 7 is not a value of enum UrsTest.Color");
    EXPECT_EQ(e.path(), "UrsTest.Containers.colors[0]");
  }
}

TEST_F(Codec, AUnionBranchMustBeTheOneItsDiscriminatorSelects) {
  EXPECT_EQ(write_error(*UrsTest::Value::descriptor(), R"(discriminator: 1 s: "one")"),
            "UrsTest.Value.discriminator: the discriminator 1 selects branch 'i' but the branch set is 's'");
  EXPECT_EQ(write_error(*UrsTest::Value::descriptor(), R"(discriminator: 7 i: 1)"),
            "UrsTest.Value.discriminator: the discriminator 7 selects branch 'flag' but the branch set is 'i'");
  EXPECT_EQ(write_error(*UrsTest::Pick::descriptor(), "discriminator: COLOR_GREEN"),
            "UrsTest.Pick.discriminator: the discriminator 1 selects branch 'p' but the branch set is none");
  EXPECT_EQ(write_error(*UrsTest::Pick::descriptor(), "discriminator: COLOR_LIGHT_BLUE r: 1"),
            "UrsTest.Pick.discriminator: the discriminator 2 selects branch none but the branch set is 'r'");
}

TEST_F(Codec, CdrThatIsNotAValueIsRefusedWhenRead) {
  const auto outer = parse(*UrsTest::Outer::descriptor(), "inside { v: 3 } state: OUTER_MODE_OFF");
  std::string cdr = write(*outer);
  ASSERT_EQ(cdr.size(), 8u);
  cdr[4] = 5;  // the enum's ordinal
  try {
    read(*UrsTest::Outer::descriptor(), cdr);
    ADD_FAILURE() << "an undeclared enum ordinal was read";
  } catch (const ConversionError& e) {
    EXPECT_STREQ(e.what(), "UrsTest.Outer.state: 5 is not a value of enum UrsTest.Outer_Mode");
  }
  EXPECT_THROW(read(*UrsTest::Outer::descriptor(), cdr.substr(0, 6)), CORBA::MARSHAL);

  // A sequence<octet> whose length runs past the end is refused before anything is allocated.
  const std::string huge("\xff\xff\xff\x7f", 4);
  cdrMemoryStream stream;
  stream.put_octet_array(reinterpret_cast<const CORBA::Octet*>(huge.data()), 4);
  auto failure = parse(*URC::Image::descriptor(), "");
  EXPECT_THROW(codec_.read_field(stream, *failure, *URC::Image::descriptor()->FindFieldByName("data")), CORBA::MARSHAL);
}

TEST_F(Codec, MessagesOutsideItsRootsAreRefused) {
  const auto echo = parse(*URS::Diagnostic_echo_Request::descriptor(), "");
  cdrMemoryStream stream;
  EXPECT_THROW(codec_.write(stream, *echo), std::invalid_argument);
  EXPECT_THROW(CdrCodec({google::protobuf::DescriptorProto::descriptor()}), std::invalid_argument);
}

}  // namespace
}  // namespace urs::test
