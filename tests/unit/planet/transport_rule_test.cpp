// The rule for tokens over plain TCP: loopback only, unless TLS or the operator's opt-in.

#include <gtest/gtest.h>

#include "urs/planet/server.hpp"

namespace urs::planet {
namespace {

TEST(PlanetTokenTransport, PlainTcpTokensFromLoopbackOnlyUnlessTlsOrOptIn) {
  for (const char* loopback : {"127.0.0.1", "127.3.2.1", "::1", "::ffff:127.0.0.1"}) {
    EXPECT_TRUE(token_transport_allowed(false, false, loopback)) << loopback;
  }
  for (const char* remote : {"192.0.2.7", "10.0.0.1", "::ffff:192.0.2.7", "fd00::2", "0.0.0.0", "?", ""}) {
    EXPECT_FALSE(token_transport_allowed(false, false, remote)) << remote;
    EXPECT_TRUE(token_transport_allowed(true, false, remote)) << remote << " over TLS";
    EXPECT_TRUE(token_transport_allowed(false, true, remote)) << remote << " with --allow-plaintext-tokens";
  }
}

}  // namespace
}  // namespace urs::planet
