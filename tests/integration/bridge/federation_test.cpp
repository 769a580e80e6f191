// Two spaces linked only over DDS (real Fast DDS participants, UDP only, as between containers):
// "jp" is an RT-Middleware space (omniNames, urs-rtc-manager with a Diagnostic RTC, urs-bridge
// with no CAMUS server) and "kr" a CAMUS space (urs-camus-server, urs-sam with the diagnostic
// agent, urs-bridge with no naming service). Each space's services are callable from the other
// under the other space's prefix; a dead bridge's services vanish within the lease and return
// with it; a restarted CAMUS server gets the imported services back; filters and loop prevention
// keep the catalogs as configured.

#include <gtest/gtest.h>
#include <unistd.h>

#include <future>
#include <iostream>

#include "Diagnostic.pb.h"
#include "bridge_fixture.hpp"
#include "urs/corba_agent/corba_proxy.hpp"

namespace urs::test {
namespace {

using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;
namespace gp = google::protobuf;

constexpr auto kLease = 1500ms;

class Federation : public BridgeSpaceTest {
 protected:
  void SetUp() override {
    space_ = "kr";
    BridgeSpaceTest::SetUp();
    if (HasFatalFailure()) return;
    domain_ = 100 + static_cast<int>(getpid() % 100);  // tests running side by side stay apart
    start_manager("m", "jphost", "components:\n  - type: Diagnostic\n  - type: Diagnostic\n    instance: Secret0\n");
    start_jp();
    kr_ = launch_bridge("bridge-kr",
                        "name: bridge-kr\n" + dds() +
                            "  export: {allow: [\"*\"], deny: []}\n"
                            "  import: {as_rtc: \"\"}\n",
                        {"--server", server_address_});
  }

  void TearDown() override {
    if (HasFailure()) {
      std::cerr << "---- bridge-jp log\n" << (jp_ ? jp_->log() : "") << "---- bridge-kr log\n" << (kr_ ? kr_->log() : "");
    }
    jp_.reset();
    kr_.reset();
    BridgeSpaceTest::TearDown();
  }

  std::string dds() const {
    return "dds:\n  domain: " + std::to_string(domain_) + "\n  lease_ms: " + std::to_string(kLease.count()) +
           "\n  udp_only: true\n";
  }

  void start_jp() {
    jp_ = launch_bridge("bridge-jp",
                        "name: bridge-jp\n"
                        "rt_to_camus:\n"
                        "  poll_ms: 100\n"
                        "  providers:\n"
                        "    - {match: \"*\", name: \"rt.{instance}\", deadline_ms: 5000}\n" +
                            dds() + "  export: {deny: [\"rt.Secret*\"]}\n",
                        {"--naming", naming_->address(), "--host", "jphost"}, "jp");
  }

  Observed call(const std::string& service, const std::string& operation, const gp::Message& request,
                std::chrono::milliseconds deadline = 5s) {
    const auto r = planet_->call(service, operation, request.SerializeAsString(), deadline);
    return {r.status, r.payload, r.exception_type, r.message};
  }

  int domain_ = 0;
  std::unique_ptr<Process> jp_;
  std::unique_ptr<Process> kr_;
};

TEST_F(Federation, EachSpacesServicesAreCallableFromTheOther) {
  ASSERT_TRUE(wait_for_service("jp/rt.Diagnostic0", 20s)) << kr_->log() << jp_->log();
  EXPECT_NE(listed("jp/rt.Diagnostic0").find("dds:jp/rt.Diagnostic0"), std::string::npos);

  // kr's CAMUS client -> kr server -> bridge-kr -DDS-> bridge-jp -CORBA-> jp's RTC.
  URS::Diagnostic_echo_Request echo;
  echo.set_text("こんにちは from kr");
  const Observed echoed = call("jp/rt.Diagnostic0", "echo", echo);
  ASSERT_EQ(echoed.status, planet::OK) << echoed.message;
  URS::Diagnostic_echo_Reply echo_reply;
  ASSERT_TRUE(echo_reply.ParseFromString(echoed.payload));
  EXPECT_EQ(echo_reply.result(), echo.text());

  URS::Diagnostic_blob_Request blob;  // an image-sized reply crosses whole
  blob.set_size(921600);
  const auto started = Clock::now();
  const Observed image = call("jp/rt.Diagnostic0", "blob", blob);
  std::cout << "921600-byte reply across spaces: "
            << std::chrono::duration_cast<std::chrono::microseconds>(Clock::now() - started).count() << " us\n";
  ASSERT_EQ(image.status, planet::OK) << image.message;
  URS::Diagnostic_blob_Reply bytes;
  ASSERT_TRUE(bytes.ParseFromString(image.payload));
  ASSERT_EQ(bytes.result().size(), 921600u);
  for (std::size_t i = 0; i < bytes.result().size(); i += 4099) {
    ASSERT_EQ(static_cast<unsigned char>(bytes.result()[i]), i % 251) << "byte " << i;
  }

  URS::Diagnostic_fail_Request fail;
  fail.set_reason("wheel stuck");
  fail.set_code(12);
  const Observed raised = call("jp/rt.Diagnostic0", "fail", fail);
  EXPECT_EQ(raised.status, planet::USER_EXCEPTION);
  EXPECT_EQ(raised.exception_type, "URS.Failure");
  URS::Failure failure;
  ASSERT_TRUE(failure.ParseFromString(raised.payload));
  EXPECT_EQ(failure.reason(), "wheel stuck");
  EXPECT_EQ(failure.code(), 12);

  URS::Diagnostic_sleep_Request sleep;  // the caller's deadline crosses the border
  sleep.set_ms(3000);
  const auto slept = Clock::now();
  EXPECT_EQ(call("jp/rt.Diagnostic0", "sleep", sleep, 400ms).status, planet::DEADLINE_EXCEEDED);
  EXPECT_LT(Clock::now() - slept, 2500ms);

  // The filtered service is not offered; nothing imported is offered back.
  EXPECT_TRUE(listed("jp/rt.Secret0").empty());
  const auto all = urs({"ls"});
  EXPECT_EQ(all.out.find("kr/"), std::string::npos) << all.out;
  EXPECT_EQ(all.out.find("jp/kr"), std::string::npos) << all.out;

  // jp's side: kr's diag is an RTC in jp's naming service (bridge-jp imports as RTCs), and a
  // CORBA consumer calling it reaches kr's agent: DII -> bridge-jp -DDS-> bridge-kr -> SAM.
  ASSERT_TRUE(wait_until([&] { return bound("jphost.host_cxt/kr_diag.rtc"); }, 20s)) << jp_->log();
  CORBA::Object_var provider =
      provided_object("jphost.host_cxt/kr_diag.rtc", "diagnostic", "URS::Diagnostic", "diagnostic");
  ASSERT_FALSE(CORBA::is_nil(provider));
  corba_agent::CorbaProxyAgent consumer(test_orb().orb(), provider,
                                        *URS::Diagnostic_echo_Request::descriptor()->file()->FindServiceByName("Diagnostic"));
  agent::CallContext ctx;
  ctx.deadline = Clock::now() + 5s;
  URS::Diagnostic_echo_Request from_jp;
  from_jp.set_text("from jp's RT side");
  URS::Diagnostic_echo_Reply to_jp;
  const agent::Outcome outcome =
      consumer.invoke(*consumer.interface().FindMethodByName("echo"), from_jp, to_jp, ctx);
  EXPECT_EQ(outcome.status, planet::OK) << outcome.message;
  EXPECT_EQ(to_jp.result(), "from jp's RT side");
}

TEST_F(Federation, ADeadBridgesServicesVanishWithinTheLeaseAndReturnWithIt) {
  ASSERT_TRUE(wait_for_service("jp/rt.Diagnostic0", 20s)) << kr_->log();
  jp_->kill9();
  const auto killed = Clock::now();
  ASSERT_TRUE(wait_service_gone("jp/rt.Diagnostic0", 15s)) << kr_->log();
  const auto vanished = Clock::now() - killed;
  std::cout << "jp's services vanished from kr "
            << std::chrono::duration_cast<std::chrono::milliseconds>(vanished).count() << " ms after the kill (lease "
            << kLease.count() << " ms)\n";
  EXPECT_LT(vanished, kLease * 4);
  // Calls fail at once with a clear error rather than waiting for their deadline.
  URS::Diagnostic_echo_Request echo;
  const auto asked = Clock::now();
  const Observed failed = call("jp/rt.Diagnostic0", "echo", echo, 5s);
  EXPECT_EQ(failed.status, planet::UNKNOWN_SERVICE) << failed.message;
  EXPECT_LT(Clock::now() - asked, 1000ms);

  start_jp();
  ASSERT_TRUE(wait_for_service("jp/rt.Diagnostic0", 20s)) << kr_->log();
  echo.set_text("back");
  EXPECT_EQ(call("jp/rt.Diagnostic0", "echo", echo).status, planet::OK);

  // kr's CAMUS server dies and comes back on its port: bridge-kr registers the imports again.
  const std::string port = server_address_.substr(server_address_.rfind(':') + 1);
  server_->kill9();
  server_ = std::make_unique<Process>(
      std::vector<std::string>{URS_SERVER_BIN, "--space", space_, "--listen", "127.0.0.1:" + port, "--data-dir",
                               dir_ + "/data", "--heartbeat-ms", "200", "--heartbeat-timeout-ms", "1000"},
      dir_ + "/server2.log");
  ASSERT_TRUE(wait_for_service("jp/rt.Diagnostic0", 20s)) << kr_->log();
  ASSERT_TRUE(planet_->wait_connected(10s));
  echo.set_text("after the server restart");
  const Observed again = call("jp/rt.Diagnostic0", "echo", echo);
  EXPECT_EQ(again.status, planet::OK) << again.message;
}

}  // namespace
}  // namespace urs::test
