// Planet over TLS 1.3 against the real urs-camus-server: certificates are made at test time with
// the openssl command in a temporary directory (two CAs, a server certificate for 127.0.0.1 and
// localhost, client certificates). A call over TLS works; a server certificate from another CA is
// refused; a client certificate maps to the credential that names it (identity and role); and a
// token over plain TCP from a non-loopback address is refused unless the operator opts in.

#include <arpa/inet.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <ifaddrs.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/stat.h>

#include <filesystem>
#include <fstream>
#include <future>
#include <string>
#include <vector>

#include "camus.pb.h"
#include "certificates.hpp"
#include "process.hpp"
#include "urs/planet/client.hpp"

namespace urs::camus_server::test {
namespace {

using namespace std::chrono_literals;
using ::testing::HasSubstr;
using urs::test::Process;

// An IPv4 address of this machine other than loopback (so that a connection to it comes from a
// non-loopback source address), or empty.
std::string non_loopback_ipv4() {
  ifaddrs* list = nullptr;
  if (::getifaddrs(&list) != 0) return {};
  std::string found;
  for (ifaddrs* it = list; it != nullptr && found.empty(); it = it->ifa_next) {
    if (it->ifa_addr == nullptr || it->ifa_addr->sa_family != AF_INET) continue;
    const auto* address = reinterpret_cast<const sockaddr_in*>(it->ifa_addr);
    if ((ntohl(address->sin_addr.s_addr) >> 24) == 127) continue;
    char text[INET_ADDRSTRLEN] = {};
    ::inet_ntop(AF_INET, &address->sin_addr, text, sizeof text);
    found = text;
  }
  ::freeifaddrs(list);
  return found;
}

class TlsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = urs::test::make_temp_dir("tls");
    write(dir_ + "/viewer.token", "viewer-" + std::to_string(::getpid()) + "-token\n");
    write(dir_ + "/credentials.yaml",
          "credentials:\n"
          "  - name: viewer\n    role: client\n    token_file: viewer.token\n"
          "  - name: arm\n    role: sam\n    certificate: robot-arm.kr\n");
    urs::test::make_ca(dir_, "ca");
    urs::test::make_ca(dir_, "other-ca");
    urs::test::make_leaf(dir_, "server", "camus.kr", "ca", "IP:127.0.0.1,DNS:localhost");
    urs::test::make_leaf(dir_, "arm", "robot-arm.kr", "ca");
    urs::test::make_leaf(dir_, "stranger", "robot-arm.kr", "other-ca");
    urs::test::make_leaf(dir_, "nobody", "nobody.kr", "ca");
  }

  void TearDown() override {
    if (HasFailure() && server_) std::cerr << "---- server log\n" << server_->log();
    server_.reset();
    std::filesystem::remove_all(dir_);
  }

  static void write(const std::string& path, const std::string& text) { std::ofstream(path) << text; }

  void start_server(const std::string& listen, std::vector<std::string> extra) {
    std::vector<std::string> argv{URS_CAMUS_SERVER_BIN, "--space",       "kr",
                                  "--listen",           listen,          "--port-file",
                                  dir_ + "/port",       "--credentials", dir_ + "/credentials.yaml",
                                  "--log-level",        "debug"};
    argv.insert(argv.end(), extra.begin(), extra.end());
    std::filesystem::remove(dir_ + "/port");
    server_ = std::make_unique<Process>(argv, dir_ + "/server.log");
    ASSERT_TRUE(urs::test::wait_until([&] { return std::filesystem::exists(dir_ + "/port"); }, 20s)) << server_->log();
    port_ = static_cast<uint16_t>(std::stoi(urs::test::read_text(dir_ + "/port")));
  }
  void start_tls_server() {
    start_server("127.0.0.1:0", {"--tls-cert", dir_ + "/server.pem", "--tls-key", dir_ + "/server.key",
                                 "--tls-client-ca", dir_ + "/ca.pem"});
  }

  planet::ClientOptions options(const std::string& host = "127.0.0.1") const {
    planet::ClientOptions o;
    o.host = host;
    o.port = port_;
    o.peer_name = "tls-test";
    o.connect_timeout = 2s;
    return o;
  }
  std::string viewer_token() const {
    std::string token = urs::test::read_text(dir_ + "/viewer.token");
    token.erase(token.find_last_not_of(" \n") + 1);
    return token;
  }

  std::string dir_;
  uint16_t port_ = 0;
  std::unique_ptr<Process> server_;
};

TEST_F(TlsTest, CallsWorkOverTlsAndAServerCertificateFromAnotherCaIsRefused) {
  start_tls_server();
  ASSERT_FALSE(HasFatalFailure());
  EXPECT_THAT(server_->log(), HasSubstr("TLS 1.3, client certificates verified"));

  auto good = options();
  good.token = viewer_token();
  good.tls.enabled = true;
  good.tls.ca_file = dir_ + "/ca.pem";
  planet::Client client(good);
  client.start();
  ASSERT_TRUE(client.wait_connected(10s)) << client.last_error();
  EXPECT_EQ(client.welcome().identity(), "viewer");
  camus::ListRequest list;
  auto result = client.call("camus.registry", "List", list.SerializeAsString(), 10s);
  EXPECT_TRUE(result.ok()) << result.message;
  client.stop();

  // The urs command line, with the shared TLS flags.
  auto ls = urs::test::run_command({URS_CLI_BIN, "--server", "127.0.0.1:" + std::to_string(port_), "--token-file",
                                    dir_ + "/viewer.token", "--tls-ca", dir_ + "/ca.pem", "ls"},
                                   30s);
  EXPECT_EQ(ls.exit_code, 0) << ls.err;
  EXPECT_THAT(ls.out, HasSubstr("camus.registry"));

  // Verified against the wrong CA: the client refuses the server in the TLS handshake.
  auto wrong = good;
  wrong.tls.ca_file = dir_ + "/other-ca.pem";
  planet::Client refused(wrong);
  refused.start();
  EXPECT_FALSE(refused.wait_connected(3s));
  EXPECT_THAT(refused.last_error(), HasSubstr("TLS handshake failed"));
  EXPECT_THAT(refused.last_error(), HasSubstr("certificate verify failed"));
  refused.stop();

  // A name the certificate does not carry.
  auto misnamed = good;
  misnamed.tls.server_name = "camus.elsewhere";
  planet::Client wrong_name(misnamed);
  wrong_name.start();
  EXPECT_FALSE(wrong_name.wait_connected(3s));
  EXPECT_THAT(wrong_name.last_error(), HasSubstr("TLS handshake failed"));
  wrong_name.stop();

  // Plain TCP to a TLS server never gets a Welcome.
  auto plain = options();
  plain.token = viewer_token();
  planet::Client cleartext(plain);
  cleartext.start();
  EXPECT_FALSE(cleartext.wait_connected(3s));
  cleartext.stop();
  EXPECT_TRUE(server_->running());
}

TEST_F(TlsTest, AClientCertificateMapsToTheCredentialThatNamesIt) {
  start_tls_server();
  ASSERT_FALSE(HasFatalFailure());
  auto arm = options();
  arm.role = planet::SAM;
  arm.tls.enabled = true;
  arm.tls.ca_file = dir_ + "/ca.pem";
  arm.tls.cert_file = dir_ + "/arm.pem";
  arm.tls.key_file = dir_ + "/arm.key";
  planet::Client client(arm);
  client.start();
  ASSERT_TRUE(client.wait_connected(10s)) << client.last_error();
  EXPECT_EQ(client.welcome().identity(), "arm");
  EXPECT_EQ(client.welcome().role(), planet::SAM);
  camus::RegisterRequest registration;
  registration.mutable_service()->set_name("arm");
  registration.mutable_service()->set_interface("URC.Arm");
  std::promise<planet::CallResult> registered;
  client.register_service(registration, [&](planet::CallResult r) { registered.set_value(std::move(r)); });
  auto future = registered.get_future();
  ASSERT_EQ(future.wait_for(10s), std::future_status::ready);
  EXPECT_TRUE(future.get().ok());
  client.stop();

  // Why a client presenting certificate NAME.pem (else as `arm`) is not let in.
  auto refusal = [&](const std::string& name) {
    auto other = arm;
    other.tls.cert_file = dir_ + "/" + name + ".pem";
    other.tls.key_file = dir_ + "/" + name + ".key";
    planet::Client refused(other);
    refused.start();
    EXPECT_FALSE(refused.wait_connected(3s)) << name;
    std::string error = refused.last_error();
    refused.stop();
    return error;
  };
  // A certificate with a name no credential carries: refused at the handshake, UNAUTHENTICATED.
  EXPECT_THAT(refusal("nobody"), HasSubstr("client certificate 'nobody.kr' names no credential"));
  // The same name as arm's, signed by a CA the server does not trust: refused in the TLS handshake.
  EXPECT_THAT(refusal("stranger"), HasSubstr("alert unknown ca"));
}

TEST_F(TlsTest, TokensOverPlainTcpComeFromLoopbackUnlessTheOperatorOptsIn) {
  const std::string address = non_loopback_ipv4();
  if (address.empty()) GTEST_SKIP() << "this machine has no non-loopback IPv4 address";
  start_server("0.0.0.0:0", {});
  ASSERT_FALSE(HasFatalFailure());
  auto from_loopback = options();
  from_loopback.token = viewer_token();
  {
    planet::Client client(from_loopback);
    client.start();
    EXPECT_TRUE(client.wait_connected(10s)) << client.last_error();
    client.stop();
  }
  auto from_network = options(address);
  from_network.token = viewer_token();
  {
    planet::Client client(from_network);
    client.start();
    EXPECT_FALSE(client.wait_connected(3s));
    EXPECT_THAT(client.last_error(), HasSubstr("a token over plain TCP is accepted from loopback only"));
    client.stop();
  }
  server_.reset();
  start_server("0.0.0.0:0", {"--allow-plaintext-tokens"});
  ASSERT_FALSE(HasFatalFailure());
  from_network.port = port_;
  planet::Client client(from_network);
  client.start();
  EXPECT_TRUE(client.wait_connected(10s)) << client.last_error();
  EXPECT_EQ(client.welcome().identity(), "viewer");
  client.stop();
}

// A renewed certificate is taken on SIGHUP for the connections that follow; a broken one is
// refused and the previous one stays in force; a key replaced by a FIFO nobody writes is refused
// without blocking, and SIGTERM still stops the server at once.
TEST_F(TlsTest, SighupReloadsTheServerCertificate) {
  start_tls_server();
  ASSERT_FALSE(HasFatalFailure());
  auto connects = [&](const std::string& ca) {
    auto o = options();
    o.token = viewer_token();
    o.tls.enabled = true;
    o.tls.ca_file = dir_ + "/" + ca + ".pem";
    planet::Client client(o);
    client.start();
    const bool ok = client.wait_connected(3s);
    client.stop();
    return ok;
  };
  EXPECT_TRUE(connects("ca"));
  urs::test::make_leaf(dir_, "renewed", "camus.kr", "other-ca", "IP:127.0.0.1");
  std::filesystem::copy_file(dir_ + "/renewed.pem", dir_ + "/server.pem",
                             std::filesystem::copy_options::overwrite_existing);
  std::filesystem::copy_file(dir_ + "/renewed.key", dir_ + "/server.key",
                             std::filesystem::copy_options::overwrite_existing);
  server_->signal(SIGHUP);
  ASSERT_TRUE(
      urs::test::wait_until([&] { return server_->log().find("SIGHUP: TLS certificate") != std::string::npos; }, 10s))
      << server_->log();
  EXPECT_TRUE(connects("other-ca"));
  EXPECT_FALSE(connects("ca"));

  write(dir_ + "/server.key", "not a key\n");
  server_->signal(SIGHUP);
  ASSERT_TRUE(urs::test::wait_until(
      [&] { return server_->log().find("SIGHUP: TLS files not reloaded") != std::string::npos; }, 10s));
  EXPECT_TRUE(connects("other-ca")) << "the previous certificate stays in force";
  EXPECT_TRUE(server_->running());

  std::filesystem::remove(dir_ + "/server.key");
  ASSERT_EQ(::mkfifo((dir_ + "/server.key").c_str(), 0600), 0);
  server_->signal(SIGHUP);
  ASSERT_TRUE(urs::test::wait_until(
      [&] { return server_->log().find("is a FIFO, not a regular file") != std::string::npos; }, 10s))
      << server_->log();
  EXPECT_TRUE(connects("other-ca"));
  server_->signal(SIGTERM);
  EXPECT_EQ(server_->wait(10s), 0) << "a reload blocked the shutdown";
}

}  // namespace
}  // namespace urs::camus_server::test
