// Data ports across processes, over real GIOP: the Counter and Sink of urs-rtc-manager processes
// with ports in this process and with each other; a reader process killed mid-connection.

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <vector>

#include "BasicDataType.hh"
#include "ExtendedDataTypes.hh"
#include "rt_space.hpp"
#include "urs/rtc/data_port.hpp"
#include "urs/rtc/nvlist.hpp"
#include "urs/rtc/tools.hpp"

namespace urs::test {
namespace {

using namespace std::chrono_literals;

constexpr const char* kCounterPath = "labhost.host_cxt/Counter0.rtc";
constexpr const char* kSinkPath = "labhost.host_cxt/Sink0.rtc";

class ManagerData : public RtSpaceTest {
 protected:
  RTC::PortService_var port_of(const char* component_path, const char* port) {
    auto component = resolve<RTC::RTObject>(component_path);
    RTC::PortService_var found = rtc::find_port(component, port);
    EXPECT_FALSE(CORBA::is_nil(found)) << component_path << " has no port " << port;
    return found;
  }

  static rtc::Connection connect(RTC::PortService_ptr out, RTC::PortService_ptr in, const char* endian) {
    return rtc::connect_ports({out, in}, "data", rtc::nv_from({{"dataport.serializer.cdr.endian", endian}}));
  }

  bool logged(const std::string& name, const std::string& text) {
    return wait_until([&] { return manager(name).log().find(text) != std::string::npos; }, 10s);
  }
};

TEST_F(ManagerData, ACounterProcessWritesToInPortsHere) {
  start_manager("writer", "labhost",
                "components:\n  - type: Counter\n    rate: 50\n    activate: true\n    config: {start: 100}\n");
  rtc::InPort<RTC::TimedLong> count("count");
  rtc::InPort<RTC::TimedPose2D> pose("pose");
  count.attach(test_orb(), "Reader0", RTC::RTObject::_nil());
  pose.attach(test_orb(), "Reader0", RTC::RTObject::_nil());
  RTC::PortService_var count_here = count.reference();
  RTC::PortService_var pose_here = pose.reference();
  ASSERT_EQ(connect(port_of(kCounterPath, "count"), count_here, "big").code, RTC::RTC_OK);
  ASSERT_EQ(connect(port_of(kCounterPath, "pose"), pose_here, "little").code, RTC::RTC_OK);

  ASSERT_TRUE(wait_until([&] { return count.received() >= 5 && pose.received() >= 5; }, 10s));
  std::vector<CORBA::Long> values;
  for (RTC::TimedLong value; values.size() < 5 && count.read(value);) values.push_back(value.data);
  ASSERT_EQ(values.size(), 5U);
  EXPECT_GE(values[0], 100);
  for (std::size_t i = 1; i < values.size(); ++i) EXPECT_EQ(values[i], values[i - 1] + 1);
  const auto now = std::chrono::system_clock::now().time_since_epoch();
  const auto sent_at = std::chrono::seconds(count.latest()->tm.sec);
  EXPECT_LT(std::chrono::abs(std::chrono::duration_cast<std::chrono::seconds>(now) - sent_at), 60s);

  const auto where = pose.latest();
  ASSERT_TRUE(where);
  EXPECT_NEAR(std::hypot(where->data.position.x, where->data.position.y), 1.0, 1e-9);
  EXPECT_EQ(count.rejected(), 0U);
  EXPECT_EQ(pose.rejected(), 0U);
}

TEST_F(ManagerData, AnOutPortHereWritesToASinkProcessAndDropsItWhenItDies) {
  start_manager("reader", "labhost", "components:\n  - type: Sink\n");
  rtc::OutPort<RTC::TimedLong> out("count");
  out.attach(test_orb(), "Writer0", RTC::RTObject::_nil());
  RTC::PortService_var here = out.reference();
  ASSERT_EQ(connect(here, port_of(kSinkPath, "count"), "big").code, RTC::RTC_OK);

  for (CORBA::Long i = 1; i <= 3; ++i) {
    RTC::TimedLong value;
    value.tm.sec = 0;
    value.tm.nsec = 0;
    value.data = 1000 + i;
    EXPECT_EQ(out.write(value).delivered, 1U);
  }
  EXPECT_TRUE(logged("reader", "Sink0: count 1003 ")) << manager("reader").log();

  manager("reader").kill9();
  RTC::TimedLong value;
  value.data = 0;
  const auto result = out.write(value);
  EXPECT_EQ(result.delivered, 0U);
  EXPECT_EQ(result.dropped, 1U);
  EXPECT_EQ(out.connection_count(), 0U);
}

TEST_F(ManagerData, ACounterProcessFeedsASinkProcessConnectedByATool) {
  start_manager("writer", "labhost", "components:\n  - type: Counter\n    rate: 50\n    activate: true\n");
  start_manager("reader", "labhost", "components:\n  - type: Sink\n");
  ASSERT_EQ(connect(port_of(kCounterPath, "count"), port_of(kSinkPath, "count"), "big").code, RTC::RTC_OK);
  ASSERT_EQ(connect(port_of(kCounterPath, "pose"), port_of(kSinkPath, "pose"), "little").code, RTC::RTC_OK);
  EXPECT_TRUE(logged("reader", "Sink0: count ")) << manager("reader").log();
  EXPECT_TRUE(logged("reader", "Sink0: pose x=")) << manager("reader").log();
  EXPECT_EQ(manager("reader").log().find("rejected"), std::string::npos) << manager("reader").log();
}

}  // namespace
}  // namespace urs::test
