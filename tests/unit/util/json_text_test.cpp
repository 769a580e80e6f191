// urs::util JSON text: string literals escaped as RFC 8259 asks, bytes as RFC 4648 base64.

#include "urs/util/json_text.hpp"

#include <gtest/gtest.h>

namespace urs::util {
namespace {

TEST(JsonString, EscapesQuotesBackslashesAndControlCharacters) {
  EXPECT_EQ(json_string(""), "\"\"");
  EXPECT_EQ(json_string("a\"b\\c"), "\"a\\\"b\\\\c\"");
  EXPECT_EQ(json_string(std::string("\n\t\r\x01\0", 5)), "\"\\n\\t\\r\\u0001\\u0000\"");
  EXPECT_EQ(json_string("こんにちは"), "\"こんにちは\"");  // UTF-8 passes as it is
}

TEST(Base64, EncodesEveryLengthWithPadding) {  // RFC 4648 section 10
  EXPECT_EQ(base64(""), "");
  EXPECT_EQ(base64("f"), "Zg==");
  EXPECT_EQ(base64("fo"), "Zm8=");
  EXPECT_EQ(base64("foo"), "Zm9v");
  EXPECT_EQ(base64("foob"), "Zm9vYg==");
  EXPECT_EQ(base64("fooba"), "Zm9vYmE=");
  EXPECT_EQ(base64("foobar"), "Zm9vYmFy");
  EXPECT_EQ(base64(std::string("\xff\x00\xfe", 3)), "/wD+");
}

}  // namespace
}  // namespace urs::util
