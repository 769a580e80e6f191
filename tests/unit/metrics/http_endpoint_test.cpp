// urs::metrics::HttpEndpoint over real TCP on loopback: /metrics, /healthz, /readyz, and what a
// peer may not do (a long head, another method, a silent connection, many connections).

#include "urs/metrics/http_endpoint.hpp"

#include <arpa/inet.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <vector>

#include "metrics_scrape.hpp"

namespace urs::metrics {
namespace {

using ::testing::HasSubstr;
using ::testing::StartsWith;

struct Endpoint : ::testing::Test {
  Metrics metrics{{"urs-test", "kr"}};
  std::string why_not;
  HttpEndpoint endpoint{{"127.0.0.1", 0}, metrics};
  Endpoint() {
    metrics.health().add("listening", [this] { return why_not; });
  }
};

TEST_F(Endpoint, ServesMetricsInTheTextFormat) {
  auto response = test::http_get(endpoint.port(), "/metrics");
  EXPECT_EQ(response.status, 200);
  EXPECT_THAT(response.head, HasSubstr("Content-Type: text/plain; version=0.0.4; charset=utf-8"));
  EXPECT_EQ(test::metric_value(response.body, "urslink_build_info", {{"program", "urs-test"}}), 1);
  EXPECT_EQ(test::http_get(endpoint.port(), "/metrics?x=1").status, 200);  // the query is ignored
}

TEST_F(Endpoint, HealthzIsAliveAndReadyzFollowsTheChecks) {
  EXPECT_EQ(test::http_get(endpoint.port(), "/healthz").body, "ok\n");
  auto ready = test::http_get(endpoint.port(), "/readyz");
  EXPECT_EQ(ready.status, 200);
  EXPECT_EQ(ready.body, "ok listening\n");
  why_not = "no listener yet";
  auto not_ready = test::http_get(endpoint.port(), "/readyz");
  EXPECT_EQ(not_ready.status, 503);
  EXPECT_EQ(not_ready.body, "not ready listening: no listener yet\n");
  EXPECT_EQ(test::metric_value(test::http_get(endpoint.port(), "/metrics").body, "urslink_ready"), 0);
}

TEST_F(Endpoint, HeadHasNoBodyOtherMethodsAndPathsAreRefused) {
  auto head = test::http_exchange(endpoint.port(), "HEAD /healthz HTTP/1.1\r\n\r\n");
  EXPECT_EQ(head.status, 200);
  EXPECT_THAT(head.head, HasSubstr("Content-Length: 3"));
  EXPECT_EQ(head.body, "");
  auto post = test::http_exchange(endpoint.port(), "POST /metrics HTTP/1.1\r\nContent-Length: 0\r\n\r\n");
  EXPECT_EQ(post.status, 405);
  EXPECT_THAT(post.head, HasSubstr("Allow: GET, HEAD"));
  EXPECT_EQ(test::http_get(endpoint.port(), "/admin").status, 404);
  EXPECT_EQ(test::http_exchange(endpoint.port(), "garbage\r\n\r\n").status, 400);
}

TEST_F(Endpoint, AHeadOverItsLimitIsRefusedBeforeItIsAllRead) {
  const std::string request = "GET /metrics HTTP/1.1\r\nX-Long: " + std::string(20000, 'a') + "\r\n\r\n";
  auto response = test::http_exchange(endpoint.port(), request);
  EXPECT_EQ(response.status, 431);
  EXPECT_EQ(test::http_get(endpoint.port(), "/healthz").status, 200);  // it keeps serving
}

// Connections that send nothing hold a slot until their read times out; past the limit, a new
// connection is closed at once, and the endpoint serves again once slots free.
TEST_F(Endpoint, SilentConnectionsAreBoundedAndTimeOut) {
  std::vector<int> silent;
  for (int i = 0; i < 16; ++i) {
    const int fd = socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in address{};
    address.sin_family = AF_INET;
    address.sin_port = htons(endpoint.port());
    address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    ASSERT_EQ(connect(fd, reinterpret_cast<sockaddr*>(&address), sizeof address), 0);
    silent.push_back(fd);
  }
  EXPECT_TRUE(test::wait_until([&] { return test::http_get(endpoint.port(), "/healthz").status == 0; },
                               std::chrono::seconds(3)));
  EXPECT_TRUE(test::wait_until([&] { return test::http_get(endpoint.port(), "/healthz").status == 200; },
                               std::chrono::seconds(10)));
  for (int fd : silent) close(fd);
}

TEST(HttpEndpoint, APortInUseIsRefusedNamingTheFlag) {
  Metrics metrics({"urs-test", ""});
  HttpEndpoint first({"127.0.0.1", 0}, metrics);
  try {
    HttpEndpoint second({"127.0.0.1", first.port()}, metrics);
    FAIL();
  } catch (const util::ConfigError& e) {
    EXPECT_THAT(e.what(), StartsWith("--metrics-listen: cannot listen on 127.0.0.1:" + std::to_string(first.port())));
  }
}

}  // namespace
}  // namespace urs::metrics
