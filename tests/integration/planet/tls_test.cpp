// Planet over TLS 1.3 with the real Server and Client in process: several threads call at once
// (each writing its frames straight to the TLS stream) while large messages go both ways in
// chunks; every reply must come back whole and in its call. Certificates are made at test time
// with the openssl command.

#include <gtest/gtest.h>

#include <atomic>
#include <filesystem>
#include <thread>

#include "certificates.hpp"
#include "process.hpp"
#include "support.hpp"
#include "urs/planet/client.hpp"
#include "urs/planet/server.hpp"

namespace urs::planet::testing {
namespace {

std::string pattern(size_t size, size_t seed) {
  std::string out(size, '\0');
  for (size_t i = 0; i < size; ++i) out[i] = static_cast<char>((i * 31 + seed) % 251);
  return out;
}

TEST(PlanetTls, ConcurrentCallsAndLargeMessagesStayWholeOverTls) {
  const std::string dir = urs::test::make_temp_dir("planet-tls");
  urs::test::make_ca(dir, "ca");
  urs::test::make_leaf(dir, "server", "server", "ca", "IP:127.0.0.1");
  TestHandler handler;
  ServerOptions options = server_options();
  options.tls.cert_file = dir + "/server.pem";
  options.tls.key_file = dir + "/server.key";
  StartedServer server(handler, options);
  ClientOptions client_tls = client_options(server.port(), "tls-client");
  client_tls.tls.enabled = true;
  client_tls.tls.ca_file = dir + "/ca.pem";
  Client client(client_tls);
  client.start();
  ASSERT_TRUE(client.wait_connected(10s)) << client.last_error();

  std::atomic<int> ok{0};
  std::vector<std::string> failures;
  std::mutex failures_mutex;
  auto fail = [&](const std::string& what) {
    std::lock_guard<std::mutex> lock(failures_mutex);
    failures.push_back(what);
  };
  std::vector<std::thread> callers;
  constexpr int kThreads = 4;
  constexpr int kCalls = 150;
  for (int t = 0; t < kThreads; ++t) {
    callers.emplace_back([&, t] {
      for (int i = 0; i < kCalls; ++i) {
        // Mostly small calls; every 25th carries 300,000 bytes (chunked both ways).
        const size_t size = i % 25 == 0 ? 300000 : static_cast<size_t>((i * 7919 + t * 104729) % 3000);
        const std::string payload = pattern(size, static_cast<size_t>(t * 1000 + i));
        CallResult result = client.call("echo", "x", payload, 20s);
        if (!result.ok()) {
          fail(std::string(status_name(result.status)) + " " + result.message);
        } else if (result.payload != payload) {
          fail("call " + std::to_string(i) + " of thread " + std::to_string(t) + ": the echo differs");
        } else {
          ++ok;
        }
      }
    });
  }
  for (auto& caller : callers) caller.join();
  EXPECT_TRUE(failures.empty()) << failures.size() << " failed, first: " << failures.front();
  EXPECT_EQ(ok.load(), kThreads * kCalls);
  EXPECT_TRUE(client.connected());
  client.stop();
  server.stop();
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace urs::planet::testing
