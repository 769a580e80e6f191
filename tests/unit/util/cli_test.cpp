// urs::util: flag values are validated with messages that name the flag and the value.

#include "urs/util/cli.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>

namespace urs::util {
namespace {

std::string error_of(const std::string& text) {
  try {
    parse_endpoint(text, "--listen");
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "";
}

TEST(Endpoint, ParsesHostAndPort) {
  auto e = parse_endpoint("127.0.0.1:7600", "--listen");
  EXPECT_EQ(e.host, "127.0.0.1");
  EXPECT_EQ(e.port, 7600);
  auto v6 = parse_endpoint("[::1]:0", "--listen");
  EXPECT_EQ(v6.host, "::1");
  EXPECT_EQ(v6.port, 0);
}

TEST(Endpoint, RejectsWithFlagAndValue) {
  EXPECT_EQ(error_of("localhost"), "--listen: 'localhost' is not HOST:PORT");
  EXPECT_EQ(error_of("h:70000"), "--listen: port 70000 in 'h:70000' is over 65535");
  EXPECT_EQ(error_of("h:x1"), "--listen: port 'x1' in 'h:x1' is not a number 0..65535");
  EXPECT_EQ(error_of("[::1]7"), "--listen: '[::1]7' is not [IPV6]:PORT");
}

TEST(TokenFile, TrimsAndRejectsEmptyOrMissing) {
  std::string path = "/tmp/urs-token-test";
  std::ofstream(path) << "  abc \n";
  EXPECT_EQ(read_token_file(path), "abc");
  std::ofstream(path) << " \n";
  EXPECT_THROW(read_token_file(path), ConfigError);
  std::remove(path.c_str());
  EXPECT_THROW(read_token_file("/nonexistent/token"), ConfigError);
  EXPECT_EQ(read_token_file(""), "");
}

TEST(Logging, UnknownLevelIsRefused) {
  try {
    init_logging("t", "loud");
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_THAT(e.what(), ::testing::HasSubstr("unknown level 'loud'"));
  }
}

}  // namespace
}  // namespace urs::util
