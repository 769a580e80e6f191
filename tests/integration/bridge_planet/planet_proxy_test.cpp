// A CAMUS service offered as a CORBA object through the Planet proxy: urs-camus-server and urs-sam
// (the diagnostic agent as "diag") are real processes; this process fetches diag's interface from
// the registry, hosts a ForwardingAgent over Planet for it (bridge::planet_forwarder) in a
// corba_agent::AgentServant, and calls that object with the static stubs of URS::Diagnostic, as any
// CORBA client would.

#include <gtest/gtest.h>

#include <chrono>
#include <iostream>

#include "Diagnostic.hh"
#include "space_fixture.hpp"
#include "urs/bridge/camus/planet_forwarding.hpp"
#include "urs/corba_agent/agent_servant.hpp"
#include "urs/diagnostic/diagnostic.hpp"
#include "urs/rtc/orb.hpp"

namespace urs::test {
namespace {

using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;

// The proxy publishes nothing; the servant still needs a sink for its CallContext.
class NoEvents : public agent::EventSink {
 public:
  call::Reply publish(const std::string& topic, const google::protobuf::Message&) override {
    return call::Reply::error(call::Status::UNAVAILABLE, "unexpected event on " + topic);
  }
};

// One ORB per process, kept until exit: it serves the proxy's object and makes the stub calls.
rtc::Orb& orb() {
  static rtc::Orb instance;
  return instance;
}

double milliseconds_since(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

class CamusForwardingTest : public SpaceTest {
 protected:
  static constexpr auto kServantDeadline = 3000ms;  // below the SAM's 5000 ms for diag

  void SetUp() override {
    SpaceTest::SetUp();
    if (HasFatalFailure()) return;
    planet::ClientOptions options;
    options.port = static_cast<uint16_t>(port_);
    options.token = "s3cret-token";
    options.peer_name = "bridge";
    client_ = std::make_shared<planet::Client>(options);
    client_->start();
    ASSERT_TRUE(client_->wait_connected(5s)) << client_->last_error();
    const google::protobuf::ServiceDescriptor* interface = nullptr;
    try {
      interface = &bridge::describe_service(*client_, "diag", pool_);
    } catch (const std::exception& e) {
      FAIL() << e.what();
    }
    // Learnt at run time: not the compiled-in description of URS.Diagnostic.
    ASSERT_NE(interface->file()->pool(), google::protobuf::DescriptorPool::generated_pool());
    servant_ = std::make_unique<corba_agent::AgentServant>(
        orb().orb(), bridge::planet_forwarder(client_, "diag", *interface), events_,
        corba_agent::AgentServantOptions{"bridge.diag", kServantDeadline});
    CORBA::Object_var object = orb().activate(servant_.get());
    diag_ = URS::Diagnostic::_narrow(object);
    ASSERT_FALSE(CORBA::is_nil(diag_));
  }

  void TearDown() override {
    if (servant_) orb().deactivate(servant_.get());
    servant_.reset();
    if (client_) client_->stop();
    SpaceTest::TearDown();
  }

  schema::SchemaPool pool_;  // outlives the agent and its messages
  std::shared_ptr<planet::Client> client_;
  NoEvents events_;
  std::unique_ptr<corba_agent::AgentServant> servant_;
  URS::Diagnostic_var diag_;
};

TEST_F(CamusForwardingTest, OperationsAnswerThroughTheProxyAsTheCamusServiceDoes) {
  EXPECT_EQ(servant_->repository_id(), "IDL:URS/Diagnostic:1.0");
  CORBA::String_var echoed = diag_->echo("through the bridge");
  EXPECT_STREQ(echoed.in(), "through the bridge");
  EXPECT_DOUBLE_EQ(diag_->add(1.5, 2.25), 3.75);

  auto start = Clock::now();
  URS::OctetSeq_var image = diag_->blob(921600);
  const double blob_ms = milliseconds_since(start);
  ASSERT_EQ(image->length(), 921600u);
  EXPECT_EQ(image[250], 250);
  EXPECT_EQ(image[251], 0);
  EXPECT_EQ(image[921599], 921599 % 251);
  start = Clock::now();
  const uint64_t checksum = diag_->checksum(image.in());
  const double checksum_ms = milliseconds_since(start);
  EXPECT_EQ(checksum, diagnostic::fnv1a64(image->get_buffer(), image->length()));

  start = Clock::now();
  constexpr int kEchoes = 50;
  for (int i = 0; i < kEchoes; ++i) CORBA::String_var ignored = diag_->echo("ping");
  std::cout << "CORBA -> proxy -> Planet -> urs-sam, loopback:\n"
            << "  echo(\"ping\")         " << milliseconds_since(start) / kEchoes << " ms (mean of " << kEchoes << ")\n"
            << "  blob(921600)         " << blob_ms << " ms\n"
            << "  checksum(921600 B)   " << checksum_ms << " ms\n";
}

TEST_F(CamusForwardingTest, DeclaredExceptionArrivesAsTheIdlExceptionWithItsFields) {
  try {
    diag_->fail("door jammed", -42);
    ADD_FAILURE() << "fail() returned";
  } catch (const URS::Failure& failure) {
    EXPECT_STREQ(failure.reason.in(), "door jammed");
    EXPECT_EQ(failure.code, -42);
  }
}

TEST_F(CamusForwardingTest, CallOutlastingTheDeadlineIsTimeoutAndTheProxyStaysUsable) {
  EXPECT_THROW(diag_->sleep(4500), CORBA::TIMEOUT);
  CORBA::String_var echoed = diag_->echo("still here");
  EXPECT_STREQ(echoed.in(), "still here");
}

TEST_F(CamusForwardingTest, OnewayNotifyReachesAWatcher) {
  Process watcher({URS_CLI_BIN, "--server", server_address(), "--token-file", dir_ + "/token", "watch", "lab/#",
                   "--count", "1", "--for-ms", "10000"},
                  dir_ + "/watch.log");
  // The watch subscription is in place once an event reaches it; notify until one does.
  ASSERT_TRUE(wait_until(
      [&] {
        diag_->notify("lab/door", "opened");
        return !watcher.running();
      },
      10s));
  EXPECT_EQ(watcher.wait(1s), 0);
  EXPECT_NE(watcher.log().find("\"topic\":\"lab/door\""), std::string::npos) << watcher.log();
  EXPECT_NE(watcher.log().find("\"text\":\"opened\""), std::string::npos) << watcher.log();
}

TEST_F(CamusForwardingTest, ServiceProviderGoneIsTransient) {
  CORBA::String_var echoed = diag_->echo("before");
  sam_->kill9();
  const auto start = Clock::now();
  EXPECT_THROW(diag_->echo("after"), CORBA::TRANSIENT);
  std::cout << "TRANSIENT " << milliseconds_since(start) << " ms after urs-sam was killed\n";
  // And so it stays while no provider is back.
  EXPECT_THROW(diag_->add(1, 2), CORBA::TRANSIENT);
}

}  // namespace
}  // namespace urs::test
