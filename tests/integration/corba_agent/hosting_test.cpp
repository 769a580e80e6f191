// Service agents hosted as CORBA objects and RT-Components, called through omniidl's static stubs
// exactly as any CORBA client would: the diagnostic agent over the wire in a peer process (next to
// a static servant, the baseline for an image-sized blob) and in urs-rtc-manager; a URC interface
// with attributes and declared exceptions; an agent's events leaving through a data port as the
// CDR of their IDL struct. Compiled with the stubs' modules renamed (see CMakeLists.txt).

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <mutex>
#include <sstream>

#include "Diagnostic.hh"
#include "Navigation.hh"
#include "fake_navigation.hpp"
#include "rt_space.hpp"
#include "urs/corba_agent/agent_component.hpp"
#include "urs/corba_agent/agent_servant.hpp"
#include "urs/diagnostic/diagnostic.hpp"
#include "urs/rtc/data_port.hpp"
#include "urs/rtc/nvlist.hpp"
#include "urs/rtc/tools.hpp"

namespace urs::test {
namespace {

using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;

// Events the agents publish, as "<topic>: <message in text format>".
class RecordingSink : public agent::EventSink {
 public:
  call::Reply publish(const std::string& topic, const google::protobuf::Message& event) override {
    std::lock_guard lock(mutex_);
    events_.push_back(topic + ": " + event.ShortDebugString());
    return call::Reply::success({});
  }
  std::vector<std::string> events() const {
    std::lock_guard lock(mutex_);
    return events_;
  }

 private:
  mutable std::mutex mutex_;
  std::vector<std::string> events_;
};

// ---- the diagnostic agent over the wire, next to a static servant ----

class DiagnosticPeer : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = make_temp_dir("corba-agent");
    const std::string iors = dir_ + "/iors";
    peer_ = std::make_unique<Process>(std::vector<std::string>{URS_DIAGNOSTIC_PEER_BIN, iors}, dir_ + "/peer.log");
    ASSERT_TRUE(wait_until([&] { return std::filesystem::exists(iors); }, 20s)) << peer_->log();
    std::istringstream lines(read_text(iors));
    std::string dsi_ior;
    std::string static_ior;
    std::getline(lines, dsi_ior);
    std::getline(lines, static_ior);
    CORBA::Object_var dsi = test_orb().string_to_object(dsi_ior);
    CORBA::Object_var baseline = test_orb().string_to_object(static_ior);
    dsi_ = URS::Diagnostic::_narrow(dsi);
    static_ = URS::Diagnostic::_narrow(baseline);
    ASSERT_FALSE(CORBA::is_nil(dsi_));
  }
  void TearDown() override {
    if (HasFailure() && peer_) std::cerr << "---- peer log\n" << peer_->log();
    peer_.reset();
    std::filesystem::remove_all(dir_);
  }

  std::string dir_;
  std::unique_ptr<Process> peer_;
  URS::Diagnostic_var dsi_;
  URS::Diagnostic_var static_;
};

TEST_F(DiagnosticPeer, EveryOperationAnswersThroughTheDsi) {
  EXPECT_TRUE(dsi_->_is_a("IDL:URS/Diagnostic:1.0"));
  EXPECT_FALSE(dsi_->_is_a("IDL:URC/Navigation:1.0"));
  EXPECT_FALSE(dsi_->_non_existent());
  CORBA::String_var echoed = dsi_->echo("héllo");
  EXPECT_STREQ(echoed.in(), "héllo");
  EXPECT_DOUBLE_EQ(dsi_->add(1.5, 2.25), 3.75);

  URS::OctetSeq_var image = dsi_->blob(921600);
  ASSERT_EQ(image->length(), 921600u);
  const std::string expected = diagnostic::patterned_bytes(921600);
  EXPECT_TRUE(std::equal(expected.begin(), expected.end(), reinterpret_cast<const char*>(image->get_buffer())));
  EXPECT_EQ(dsi_->checksum(image.in()), diagnostic::fnv1a64(expected.data(), expected.size()));
  URS::OctetSeq empty;
  EXPECT_EQ(dsi_->checksum(empty), diagnostic::fnv1a64(nullptr, 0));

  try {
    dsi_->fail("on purpose", -42);
    ADD_FAILURE() << "fail() returned";
  } catch (const URS::Failure& failure) {
    EXPECT_STREQ(failure.reason.in(), "on purpose");
    EXPECT_EQ(failure.code, -42);
  }

  const auto before = Clock::now();
  dsi_->sleep(20);
  EXPECT_GE(Clock::now() - before, 20ms);
  EXPECT_THROW(dsi_->sleep(diagnostic::kMaxSleepMs + 1), CORBA::BAD_PARAM);  // BAD_ARGUMENTS
  EXPECT_THROW(dsi_->blob(diagnostic::kMaxBlobBytes + 1), CORBA::BAD_PARAM);
  dsi_->notify("topic", "oneway");  // no reply; the next call still works
  echoed = dsi_->echo("after");
  EXPECT_STREQ(echoed.in(), "after");
}

// Prints the median of `calls` calls of `call` in microseconds, and returns it.
template <typename F>
double median_us(int calls, F&& call) {
  std::vector<double> times;
  for (int i = 0; i < calls; ++i) {
    const auto start = Clock::now();
    call();
    times.push_back(std::chrono::duration<double, std::micro>(Clock::now() - start).count());
  }
  std::sort(times.begin(), times.end());
  return times[times.size() / 2];
}

TEST_F(DiagnosticPeer, AnImageSizedBlobCrossesTheDsiLikeAStaticServant) {
  constexpr int kCalls = 30;
  URS::OctetSeq_var from_static = static_->blob(921600);
  URS::OctetSeq_var from_dsi = dsi_->blob(921600);
  ASSERT_EQ(from_dsi->length(), from_static->length());
  EXPECT_TRUE(
      std::equal(from_dsi->get_buffer(), from_dsi->get_buffer() + from_dsi->length(), from_static->get_buffer()));
  EXPECT_EQ(dsi_->checksum(from_static.in()), static_->checksum(from_static.in()));

  const double blob_dsi = median_us(kCalls, [&] { URS::OctetSeq_var b = dsi_->blob(921600); });
  const double blob_static = median_us(kCalls, [&] { URS::OctetSeq_var b = static_->blob(921600); });
  const double checksum_dsi = median_us(kCalls, [&] { dsi_->checksum(from_static.in()); });
  const double checksum_static = median_us(kCalls, [&] { static_->checksum(from_static.in()); });
  const double echo_dsi = median_us(200, [&] { CORBA::String_var s = dsi_->echo("ping"); });
  const double echo_static = median_us(200, [&] { CORBA::String_var s = static_->echo("ping"); });
  std::cout << "median over the loopback, DSI vs static servant (us):\n"
            << "  blob(921600)        " << blob_dsi << " vs " << blob_static << "\n"
            << "  checksum(921600 B)  " << checksum_dsi << " vs " << checksum_static << "\n"
            << "  echo(\"ping\")        " << echo_dsi << " vs " << echo_static << "\n";
}

// ---- a URC interface with attributes, in this process ----

TEST(NavigationThroughTheDsi, AttributesOperationsAndDeclaredExceptionsAnswerAsIdlSays) {
  RecordingSink events;
  corba_agent::AgentServant servant(test_orb().orb(), make_fake_navigation(), events, {"nav"});
  EXPECT_EQ(servant.repository_id(), "IDL:URC/Navigation:1.0");
  EXPECT_EQ(servant.interface_name(), "URC::Navigation");
  CORBA::Object_var object = test_orb().activate(&servant);
  URC::Navigation_var navigation = URC::Navigation::_narrow(object);
  ASSERT_FALSE(CORBA::is_nil(navigation));

  EXPECT_EQ(navigation->speed(), 200u);  // _get_speed
  EXPECT_EQ(navigation->max_speed(), 800u);
  EXPECT_EQ(navigation->state(), URC::IDLE);
  try {
    navigation->moveTo(300, -1);
    ADD_FAILURE() << "an unreachable target was accepted";
  } catch (const URC::InvalidTarget& refused) {
    EXPECT_DOUBLE_EQ(refused.x, 300);
    EXPECT_DOUBLE_EQ(refused.y, -1);
    EXPECT_STREQ(refused.reason.in(), "farther than 100 m");
  }
  navigation->moveTo(1.5, -2);
  EXPECT_EQ(navigation->state(), URC::MOVING);
  const URC::Pose2D pose = navigation->getPosition();
  EXPECT_DOUBLE_EQ(pose.x, 1.5);
  EXPECT_DOUBLE_EQ(pose.y, -2);
  try {
    navigation->setSpeed(900);
    ADD_FAILURE() << "a speed over the limit was accepted";
  } catch (const URC::InvalidArgument& refused) {
    EXPECT_STREQ(refused.parameter.in(), "speed");
  }
  navigation->setSpeed(500);
  EXPECT_EQ(navigation->speed(), 500u);
  navigation->stop();
  EXPECT_EQ(navigation->state(), URC::STOPPED);
  EXPECT_EQ(events.events(), std::vector<std::string>{"pose: x: 1.5 y: -2"});
  test_orb().deactivate(&servant);
}

// ---- the RT-Component: its service port and an event stream ----

struct PoseReader : rtc::InPort<URC::Pose2D> {
  PoseReader() : rtc::InPort<URC::Pose2D>("pose") { attach(test_orb(), "Reader0", RTC::RTObject::_nil()); }
};

struct NavigationUser : rtc::CorbaPort {
  NavigationUser() : rtc::CorbaPort("navigation"), consumer(require("navigation", "URC::Navigation")) {
    attach(test_orb(), "User0", RTC::RTObject::_nil());
  }
  ~NavigationUser() override { detach(); }
  rtc::Consumer& consumer;
};

// Components are servants: the ORB must exist before one is constructed.
class HostedComponent : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { test_orb(); }
};

TEST_F(HostedComponent, ItsPortServesTheAgentAndEventsLeaveAsIdlStructs) {
  corba_agent::AgentComponent component({"Navigation", "", "", {{"pose", "pose", "URC.Pose2D"}}},
                                        make_fake_navigation());
  component.setup(test_orb(), "Navigation0", 100.0);
  ASSERT_EQ(component.initialize(), RTC::RTC_OK);
  EXPECT_EQ(component.config().port, "navigation");
  EXPECT_EQ(component.config().interface_instance, "navigation");
  ASSERT_NE(component.out_port("pose"), nullptr);
  EXPECT_EQ(component.out_port("pose")->data_type(), "IDL:URC/Pose2D:1.0");

  RTC::RTObject_var rtc = component.reference();
  RTC::PortService_var service = rtc::find_port(rtc, "navigation");
  RTC::PortService_var out = rtc::find_port(rtc, "pose");
  NavigationUser user;
  PoseReader reader;
  RTC::PortService_var user_port = user.reference();
  RTC::PortService_var reader_port = reader.reference();
  ASSERT_EQ(rtc::connect_ports({user_port.in(), service.in()}, "service").code, RTC::RTC_OK);
  ASSERT_EQ(rtc::connect_ports({out.in(), reader_port.in()}, "data").code, RTC::RTC_OK);

  URC::Navigation_var navigation = user.consumer.get<URC::Navigation>();
  ASSERT_FALSE(CORBA::is_nil(navigation));
  navigation->moveTo(3, 4);
  const auto pose = reader.latest();
  ASSERT_TRUE(pose.has_value());  // a flush connection delivers before write() returns
  EXPECT_DOUBLE_EQ(pose->x, 3);
  EXPECT_DOUBLE_EQ(pose->y, 4);
  EXPECT_DOUBLE_EQ(pose->theta, 0);
  EXPECT_EQ(component.exit(), RTC::RTC_OK);
}

TEST_F(HostedComponent, StreamsMustNameIdlStructsOfTheAgentsPool) {
  using Config = corba_agent::AgentComponentConfig;
  EXPECT_THROW(
      corba_agent::AgentComponent(Config{"N", "", "", {{"pose", "pose", "URC.NoSuchType"}}}, make_fake_navigation()),
      std::invalid_argument);
  EXPECT_THROW(corba_agent::AgentComponent(Config{"N", "", "", {{"pose", "pose", "URC.Navigation_moveTo_Request"}}},
                                           make_fake_navigation()),
               std::invalid_argument);
  EXPECT_THROW(
      corba_agent::AgentComponent(Config{"N", "", "", {{"pose", "a", "URC.Pose2D"}, {"pose", "b", "URC.Pose2D"}}},
                                  make_fake_navigation()),
      std::invalid_argument);
}

// ---- the diagnostic agent in urs-rtc-manager ----

class ManagedDiagnostic : public RtSpaceTest {};

TEST_F(ManagedDiagnostic, TheGenericDiagnosticComponentAnswersAndLogsUnroutedEvents) {
  start_manager("m", "labhost", "components:\n  - type: Diagnostic\n    config: {interface_instance: diag}\n");
  CORBA::Object_var object =
      provided_object("labhost.host_cxt/Diagnostic0.rtc", "diagnostic", "URS::Diagnostic", "diag");
  ASSERT_FALSE(CORBA::is_nil(object));
  URS::Diagnostic_var diagnostic = URS::Diagnostic::_narrow(object);
  EXPECT_THROW(diagnostic->sleep(diagnostic::kMaxSleepMs + 1), CORBA::BAD_PARAM);
  diagnostic->notify("alerts", "hello");
  EXPECT_TRUE(wait_until([&] { return manager("m").log().find("event on topic 'alerts'") != std::string::npos; }, 5s))
      << manager("m").log();
}

TEST_F(ManagedDiagnostic, UnknownConfigKeysAreRefused) {
  const std::string config = dir_ + "/bad.yaml";
  std::ofstream(config) << "components:\n  - type: Diagnostic\n    config: {colour: red}\n";
  auto result =
      run_command({URS_RTC_MANAGER_BIN, "--space", "lab", "--naming", naming_->address(), "--config", config});
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_NE(result.err.find("config.colour: unknown key"), std::string::npos) << result.err;
}

}  // namespace
}  // namespace urs::test
