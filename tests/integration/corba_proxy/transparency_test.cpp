// CorbaProxyAgent is transparent: a client calling through an AgentHost observes the same status,
// reply bytes and exception (type and fields) whether the host runs the diagnostic agent itself
// or a proxy to the Diagnostic RT-Component of a real urs-rtc-manager. Also: a provider killed
// mid-call answers UNAVAILABLE instead of hanging, and a slow call does not hold up others.

#include <gtest/gtest.h>

#include <chrono>
#include <future>
#include <iostream>
#include <memory>
#include <vector>

#include "Diagnostic.pb.h"
#include "rt_space.hpp"
#include "urs/agent/agent.hpp"
#include "urs/corba_agent/corba_proxy.hpp"
#include "urs/diagnostic/diagnostic.hpp"
#include "urs/diagnostic/diagnostic_agent.hpp"
#include "urs/rtc/nvlist.hpp"
#include "urs/rtc/tools.hpp"

namespace urs::test {
namespace {

using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;

// What a caller sees of one call.
struct Observed {
  call::Status status = call::Status::INTERNAL;
  std::string payload;
  std::string exception_type;
  std::string message;
};

class CorbaProxyTransparency : public RtSpaceTest {
 protected:
  void SetUp() override {
    RtSpaceTest::SetUp();
    start_manager("m", "labhost", "components:\n  - type: Diagnostic\n");
    CORBA::Object_var provider =
        provided_object("labhost.host_cxt/Diagnostic0.rtc", "diagnostic", "URS::Diagnostic", "diagnostic");
    ASSERT_FALSE(CORBA::is_nil(provider));

    const auto& interface = *URS::Diagnostic_echo_Request::descriptor()->file()->FindServiceByName("Diagnostic");
    native_ = std::make_unique<agent::AgentHost>(4, sink_);
    native_->add({"diag", std::make_shared<diagnostic::DiagnosticAgent>(), {}, 0});
    native_->start();
    proxy_ = std::make_unique<agent::AgentHost>(4, sink_);
    proxy_->add({"diag", std::make_shared<corba_agent::CorbaProxyAgent>(test_orb().orb(), provider, interface), {}, 0});
    proxy_->start();
  }

  void TearDown() override {
    proxy_.reset();
    native_.reset();
    RtSpaceTest::TearDown();
  }

  // Sends the call; the answer comes through the returned future.
  static std::future<Observed> send(agent::AgentHost& host, const std::string& operation,
                                    const google::protobuf::Message& request, std::uint32_t deadline_ms = 0) {
    call::Request sent;
    sent.service = "diag";
    sent.operation = operation;
    sent.payload = request.SerializeAsString();
    if (deadline_ms != 0) sent.deadline = Clock::now() + std::chrono::milliseconds(deadline_ms);
    auto promise = std::make_shared<std::promise<Observed>>();
    auto future = promise->get_future();
    host.dispatch(std::move(sent), call::Responder::from_callback([promise](call::Reply result) {
                    promise->set_value({result.status, result.payload, result.exception_type, result.message});
                  }));
    return future;
  }

  // As a Planet client observes a call: it gives up when its deadline passes.
  static Observed observe(agent::AgentHost& host, const std::string& operation,
                          const google::protobuf::Message& request, std::uint32_t deadline_ms = 0) {
    auto future = send(host, operation, request, deadline_ms);
    const auto patience = deadline_ms == 0 ? std::chrono::milliseconds(20000) : std::chrono::milliseconds(deadline_ms);
    if (future.wait_for(patience) != std::future_status::ready) {
      return {call::Status::DEADLINE_EXCEEDED, "", "", "the client gave up"};
    }
    return future.get();
  }

  // The same call through both hosts; they must be indistinguishable. Returns the proxy's.
  Observed expect_same(const std::string& operation, const google::protobuf::Message& request,
                       std::uint32_t deadline_ms = 0) {
    const Observed native = observe(*native_, operation, request, deadline_ms);
    const Clock::time_point start = Clock::now();
    const Observed proxied = observe(*proxy_, operation, request, deadline_ms);
    std::cout << operation << " through the proxy: " << call::status_name(proxied.status) << " after "
              << std::chrono::duration_cast<std::chrono::microseconds>(Clock::now() - start).count() << " us\n";
    EXPECT_EQ(proxied.status, native.status) << operation << ": " << native.message << " / " << proxied.message;
    EXPECT_EQ(proxied.payload, native.payload) << operation;
    EXPECT_EQ(proxied.exception_type, native.exception_type) << operation;
    return proxied;
  }

  agent::DiscardingEventSink sink_;
  std::unique_ptr<agent::AgentHost> native_;
  std::unique_ptr<agent::AgentHost> proxy_;
};

TEST_F(CorbaProxyTransparency, ResultsArriveAsFromTheAgentItself) {
  URS::Diagnostic_echo_Request echo;
  echo.set_text("héllo, RT side");
  EXPECT_EQ(expect_same("echo", echo).status, call::Status::OK);

  URS::Diagnostic_add_Request add;
  add.set_a(2.5);
  add.set_b(-40.25);
  EXPECT_EQ(expect_same("add", add).status, call::Status::OK);
}

TEST_F(CorbaProxyTransparency, AnImageSizedBlobAndItsChecksumMatch) {
  URS::Diagnostic_blob_Request blob;
  blob.set_size(921600);
  const Observed proxied = expect_same("blob", blob);
  ASSERT_EQ(proxied.status, call::Status::OK);
  URS::Diagnostic_blob_Reply reply;
  ASSERT_TRUE(reply.ParseFromString(proxied.payload));
  ASSERT_EQ(reply.result().size(), 921600u);

  URS::Diagnostic_checksum_Request checksum;
  checksum.set_data(reply.result());
  const Observed summed = expect_same("checksum", checksum);
  URS::Diagnostic_checksum_Reply sum;
  ASSERT_TRUE(sum.ParseFromString(summed.payload));
  EXPECT_EQ(sum.result(), diagnostic::fnv1a64(reply.result().data(), reply.result().size()));
}

TEST_F(CorbaProxyTransparency, TheDeclaredExceptionKeepsItsFields) {
  URS::Diagnostic_fail_Request fail;
  fail.set_reason("wheel jammed");
  fail.set_code(-17);
  const Observed proxied = expect_same("fail", fail);
  ASSERT_EQ(proxied.status, call::Status::USER_EXCEPTION);
  EXPECT_EQ(proxied.exception_type, "URS.Failure");
  URS::Failure failure;
  ASSERT_TRUE(failure.ParseFromString(proxied.payload));
  EXPECT_EQ(failure.reason(), "wheel jammed");
  EXPECT_EQ(failure.code(), -17);
}

TEST_F(CorbaProxyTransparency, DeadlinesAndRefusedArgumentsMapAlike) {
  URS::Diagnostic_sleep_Request sleep;
  sleep.set_ms(200);
  EXPECT_EQ(expect_same("sleep", sleep, 50).status, call::Status::DEADLINE_EXCEEDED);
  // The proxy answers so by itself: the call to the provider does not outlive the deadline.
  const Observed own = send(*proxy_, "sleep", sleep, 50).get();
  EXPECT_EQ(own.status, call::Status::DEADLINE_EXCEEDED) << own.message;

  sleep.set_ms(diagnostic::kMaxSleepMs + 1);
  const Observed refused = expect_same("sleep", sleep);
  EXPECT_EQ(refused.status, call::Status::BAD_ARGUMENTS) << refused.message;
}

TEST_F(CorbaProxyTransparency, AProviderKilledMidCallIsUnavailableNotAHang) {
  URS::Diagnostic_sleep_Request sleep;
  sleep.set_ms(3000);
  auto pending = send(*proxy_, "sleep", sleep);
  ASSERT_EQ(pending.wait_for(300ms), std::future_status::timeout);  // in flight
  const Clock::time_point killed = Clock::now();
  manager("m").kill9();
  ASSERT_EQ(pending.wait_for(20s), std::future_status::ready);
  std::cout << "answer " << std::chrono::duration_cast<std::chrono::milliseconds>(Clock::now() - killed).count()
            << " ms after SIGKILL\n";
  const Observed gone = pending.get();
  EXPECT_EQ(gone.status, call::Status::UNAVAILABLE) << gone.message;
  EXPECT_NE(gone.message.find("provider gone"), std::string::npos) << gone.message;
}

TEST_F(CorbaProxyTransparency, ASlowCallDoesNotHoldUpTheOthers) {
  URS::Diagnostic_sleep_Request sleep;
  sleep.set_ms(1000);
  auto slow = send(*proxy_, "sleep", sleep);
  std::vector<std::future<Observed>> quick;
  for (int i = 0; i < 3; ++i) {
    URS::Diagnostic_echo_Request echo;
    echo.set_text("call " + std::to_string(i));
    quick.push_back(send(*proxy_, "echo", echo));
  }
  for (int i = 0; i < 3; ++i) {
    ASSERT_EQ(quick[i].wait_for(20s), std::future_status::ready);
    const Observed answered = quick[i].get();
    ASSERT_EQ(answered.status, call::Status::OK) << answered.message;
    URS::Diagnostic_echo_Reply reply;
    ASSERT_TRUE(reply.ParseFromString(answered.payload));
    EXPECT_EQ(reply.result(), "call " + std::to_string(i));
  }
  // Every quick answer came while the slow call was still running.
  EXPECT_EQ(slow.wait_for(0ms), std::future_status::timeout);
  ASSERT_EQ(slow.wait_for(20s), std::future_status::ready);
  EXPECT_EQ(slow.get().status, call::Status::OK);
}

}  // namespace
}  // namespace urs::test
