// Data ports with a real omniORB in one process: values pushed from an OutPort to InPorts in both
// byte orders; the exact bytes a foreign (OpenRTM-aist style) InPortCdr receives; hand-made
// payloads put into an InPort as a foreign OutPort would; subscription new; dead peers dropped;
// duplicate and unsuitable connections refused.

#include <gtest/gtest.h>

#include <condition_variable>
#include <cstdint>
#include <cstring>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

// The data types' Any operators are global functions: they must be declared before the templates
// of urs/rtc/data_port.hpp, which clang-format would otherwise put first as this file's own header.
// clang-format off
#include "BasicDataType.hh"
#include "ExtendedDataTypes.hh"
#include "urs/rtc/data_port.hpp"
// clang-format on
#include "DataPort.hh"
#include "process.hpp"
#include "urs/rtc/nvlist.hpp"
#include "urs/rtc/orb.hpp"
#include "urs/rtc/tools.hpp"

namespace urs::test {
namespace {

using namespace std::chrono_literals;
using Bytes = std::vector<std::uint8_t>;

// omniORB has one ORB per process: every test here shares it.
rtc::Orb* the_orb = nullptr;

class OrbEnvironment : public ::testing::Environment {
 public:
  void SetUp() override {
    orb_ = std::make_unique<rtc::Orb>();
    the_orb = orb_.get();
  }
  void TearDown() override {
    the_orb = nullptr;
    orb_.reset();
  }

 private:
  std::unique_ptr<rtc::Orb> orb_;
};

[[maybe_unused]] const auto* const kOrbEnvironment = ::testing::AddGlobalTestEnvironment(new OrbEnvironment);

RTC::TimedLong timed_long(CORBA::ULong sec, CORBA::ULong nsec, CORBA::Long data) {
  RTC::TimedLong value;
  value.tm.sec = sec;
  value.tm.nsec = nsec;
  value.data = data;
  return value;
}

RTC::TimedPose2D timed_pose(CORBA::ULong sec, double x, double y, double heading) {
  RTC::TimedPose2D value;
  value.tm.sec = sec;
  value.tm.nsec = 0;
  value.data.position.x = x;
  value.data.position.y = y;
  value.data.heading = heading;
  return value;
}

void append_u32(Bytes& bytes, std::uint32_t value, bool big_endian) {
  for (int i = 0; i < 4; ++i) {
    const int shift = big_endian ? 24 - 8 * i : 8 * i;
    bytes.push_back(static_cast<std::uint8_t>(value >> shift));
  }
}

// RTC::TimedLong as an OpenRTM-aist OutPort puts it: tm.sec, tm.nsec, data; no header.
Bytes timed_long_cdr(std::uint32_t sec, std::uint32_t nsec, std::int32_t data, bool big_endian) {
  Bytes bytes;
  append_u32(bytes, sec, big_endian);
  append_u32(bytes, nsec, big_endian);
  append_u32(bytes, static_cast<std::uint32_t>(data), big_endian);
  return bytes;
}

OpenRTM::CdrData cdr_data(const Bytes& bytes) {
  OpenRTM::CdrData data;
  data.length(static_cast<CORBA::ULong>(bytes.size()));
  if (!bytes.empty()) std::memcpy(data.get_buffer(), bytes.data(), bytes.size());
  return data;
}

// Ports of components "Writer0" and "Reader0", attached as those components would attach them.
template <typename T>
struct Writer : rtc::OutPort<T> {
  explicit Writer(std::string name) : rtc::OutPort<T>(std::move(name)) {
    this->attach(*the_orb, "Writer0", RTC::RTObject::_nil());
  }
};

template <typename T>
struct Reader : rtc::InPort<T> {
  explicit Reader(std::string name, std::size_t buffer_length = 64) : rtc::InPort<T>(std::move(name), buffer_length) {
    this->attach(*the_orb, "Reader0", RTC::RTObject::_nil());
  }
};

rtc::Connection connect(const std::vector<rtc::PortBase*>& ports, const SDOPackage::NVList& extra = {}) {
  std::vector<RTC::PortService_var> references;
  std::vector<RTC::PortService_ptr> pointers;
  for (rtc::PortBase* port : ports) {
    references.emplace_back(port->reference());
    pointers.push_back(references.back().in());
  }
  return rtc::connect_ports(pointers, "data", extra);
}

SDOPackage::NVList properties(const std::vector<std::pair<std::string, std::string>>& pairs) {
  return rtc::nv_from(pairs);
}

// An InPortCdr that answers as an OpenRTM-aist InPort would and records every payload.
class RecordingInPortCdr : public POA_OpenRTM::InPortCdr {
 public:
  OpenRTM::PortStatus put(const OpenRTM::CdrData& data) override {
    std::lock_guard lock(mutex_);
    payloads_.emplace_back(data.get_buffer(), data.get_buffer() + data.length());
    return answer_;
  }
  void answer(OpenRTM::PortStatus status) {
    std::lock_guard lock(mutex_);
    answer_ = status;
  }
  std::vector<Bytes> payloads() const {
    std::lock_guard lock(mutex_);
    return payloads_;
  }

 private:
  mutable std::mutex mutex_;
  OpenRTM::PortStatus answer_ = OpenRTM::PORT_OK;
  std::vector<Bytes> payloads_;
};

// A foreign InPort's transfer object, active for the scope (heap servant: the POA may release
// it after the scope ends).
class ForeignInPort {
 public:
  ForeignInPort() : servant_(new RecordingInPortCdr) {
    CORBA::Object_var object = the_orb->activate(servant_.in());
    ref_ = OpenRTM::InPortCdr::_narrow(object);
  }
  ~ForeignInPort() { die(); }
  ForeignInPort(const ForeignInPort&) = delete;
  ForeignInPort& operator=(const ForeignInPort&) = delete;

  RecordingInPortCdr* operator->() const { return servant_.in(); }
  OpenRTM::InPortCdr_ptr ref() const { return ref_.in(); }
  std::string ior() const { return the_orb->object_to_string(ref_.in()); }
  void die() { the_orb->deactivate(servant_.in()); }  // its process gone, as far as callers can tell

  // What a foreign InPort publishes in notify_connect, for `out` to read in its own.
  SDOPackage::NVList published(bool with_reference = true) const {
    SDOPackage::NVList list;
    rtc::nv_set(list, "dataport.corba_cdr.inport_ior", ior());
    if (with_reference) rtc::nv_set_object(list, "dataport.corba_cdr.inport_ref", ref_.in());
    return list;
  }

 private:
  PortableServer::Servant_var<RecordingInPortCdr> servant_;
  OpenRTM::InPortCdr_var ref_;
};

SDOPackage::NVList with(SDOPackage::NVList list, const std::vector<std::pair<std::string, std::string>>& more) {
  rtc::nv_append(list, properties(more));
  return list;
}

// ---- our OutPort to our InPort ----

class PushedValues : public ::testing::TestWithParam<const char*> {};

TEST_P(PushedValues, TimedLongAndTimedPose2DArriveIntact) {
  Writer<RTC::TimedLong> count_out("count");
  Writer<RTC::TimedPose2D> pose_out("pose");
  Reader<RTC::TimedLong> count_in("count");
  Reader<RTC::TimedPose2D> pose_in("pose");
  const auto endian = properties({{"dataport.serializer.cdr.endian", GetParam()}});
  const rtc::Connection counts = connect({&count_out, &count_in}, endian);
  const rtc::Connection poses = connect({&pose_out, &pose_in}, endian);
  ASSERT_EQ(counts.code, RTC::RTC_OK);
  ASSERT_EQ(poses.code, RTC::RTC_OK);
  EXPECT_EQ(rtc::nv_string(counts.profile.properties, "dataport.data_type"), "IDL:RTC/TimedLong:1.0");
  EXPECT_EQ(rtc::nv_string(poses.profile.properties, "dataport.data_type"), "IDL:RTC/TimedPose2D:1.0");

  EXPECT_FALSE(count_in.is_new());
  EXPECT_EQ(count_out.write(timed_long(0x01020304, 999999999, -2)).delivered, 1U);
  EXPECT_EQ(count_out.write(timed_long(7, 8, 0x7fffffff)).delivered, 1U);
  EXPECT_EQ(pose_out.write(timed_pose(5, 1.5, -2.25, 3.0)).delivered, 1U);

  EXPECT_EQ(count_in.received(), 2U);
  EXPECT_EQ(count_in.unread(), 2U);
  RTC::TimedLong count;
  ASSERT_TRUE(count_in.read(count));
  EXPECT_EQ(count.tm.sec, 0x01020304U);
  EXPECT_EQ(count.tm.nsec, 999999999U);
  EXPECT_EQ(count.data, -2);
  ASSERT_TRUE(count_in.read(count));
  EXPECT_EQ(count.data, 0x7fffffff);
  EXPECT_FALSE(count_in.read(count));
  EXPECT_FALSE(count_in.is_new());
  ASSERT_TRUE(count_in.latest());
  EXPECT_EQ(count_in.latest()->data, 0x7fffffff);

  const std::optional<RTC::TimedPose2D> pose = pose_in.latest();
  ASSERT_TRUE(pose);
  EXPECT_EQ(pose->tm.sec, 5U);
  EXPECT_EQ(pose->data.position.x, 1.5);
  EXPECT_EQ(pose->data.position.y, -2.25);
  EXPECT_EQ(pose->data.heading, 3.0);
  EXPECT_EQ(count_in.rejected(), 0U);
  EXPECT_EQ(pose_in.rejected(), 0U);
}

INSTANTIATE_TEST_SUITE_P(Endian, PushedValues, ::testing::Values("little", "big", "big,little", "LITTLE"));

TEST(DataPortProfile, NamesTheTypeAndTheProtocol) {
  Writer<RTC::TimedLong> out("count");
  Reader<RTC::CameraImage> in("image");
  RTC::PortProfile_var out_profile = out.get_port_profile();
  RTC::PortProfile_var in_profile = in.get_port_profile();
  EXPECT_STREQ(out_profile->name, "Writer0.count");
  EXPECT_EQ(rtc::nv_string(out_profile->properties, "port.port_type"), "DataOutPort");
  EXPECT_EQ(rtc::nv_string(in_profile->properties, "port.port_type"), "DataInPort");
  EXPECT_EQ(rtc::nv_string(out_profile->properties, "dataport.data_type"), "IDL:RTC/TimedLong:1.0");
  EXPECT_EQ(rtc::nv_string(in_profile->properties, "dataport.data_type"), "IDL:RTC/CameraImage:1.0");
  for (const auto* profile : {&out_profile.in(), &in_profile.in()}) {
    EXPECT_EQ(rtc::nv_string(profile->properties, "dataport.interface_type"), "corba_cdr");
    EXPECT_EQ(rtc::nv_string(profile->properties, "dataport.dataflow_type"), "push");
    EXPECT_EQ(rtc::nv_string(profile->properties, "dataport.subscription_type"), "flush,new");
  }
}

TEST(InPortBuffer, AFullBufferDropsTheOldestUnreadValueAndTheWriterStillSucceeds) {
  Writer<RTC::TimedLong> out("count");
  Reader<RTC::TimedLong> in("count", 4);
  ASSERT_EQ(connect({&out, &in}).code, RTC::RTC_OK);
  for (CORBA::Long i = 0; i < 6; ++i) EXPECT_EQ(out.write(timed_long(0, 0, i)).delivered, 1U);
  EXPECT_EQ(in.received(), 6U);
  EXPECT_EQ(in.overwritten(), 2U);
  std::vector<CORBA::Long> read;
  for (RTC::TimedLong value; in.read(value);) read.push_back(value.data);
  EXPECT_EQ(read, (std::vector<CORBA::Long>{2, 3, 4, 5}));
}

TEST(InPortCallback, SeesEveryValueAndItsExceptionDoesNotFailTheWriter) {
  Writer<RTC::TimedLong> out("count");
  Reader<RTC::TimedLong> in("count");
  std::vector<CORBA::Long> seen;
  in.on_receive([&seen](const RTC::TimedLong& value) {
    seen.push_back(value.data);
    if (value.data == 2) throw std::runtime_error("the reader cannot take 2");
  });
  ASSERT_EQ(connect({&out, &in}).code, RTC::RTC_OK);
  for (CORBA::Long i = 1; i <= 3; ++i) EXPECT_EQ(out.write(timed_long(0, 0, i)).delivered, 1U);
  EXPECT_EQ(seen, (std::vector<CORBA::Long>{1, 2, 3}));
  EXPECT_EQ(in.received(), 3U);
}

// ---- our OutPort to a foreign InPort ----

struct WireCase {
  const char* endian;
  bool with_reference;  // publish the reference too, not only the IOR string
  Bytes expected;       // RTC::TimedLong{tm {1 s, 2 ns}, data -3}
};

const Bytes kBig = {0, 0, 0, 1, 0, 0, 0, 2, 0xff, 0xff, 0xff, 0xfd};
const Bytes kLittle = {1, 0, 0, 0, 2, 0, 0, 0, 0xfd, 0xff, 0xff, 0xff};

class ForeignInPortBytes : public ::testing::TestWithParam<WireCase> {};

TEST_P(ForeignInPortBytes, GetsTheRawCdrOfTheValueInTheConnectorsByteOrder) {
  const WireCase& wire = GetParam();
  ForeignInPort foreign;
  Writer<RTC::TimedLong> out("count");
  const auto connection =
      connect({&out}, with(foreign.published(wire.with_reference), {{"dataport.serializer.cdr.endian", wire.endian}}));
  ASSERT_EQ(connection.code, RTC::RTC_OK);
  EXPECT_EQ(out.connection_count(), 1U);

  EXPECT_EQ(out.write(timed_long(1, 2, -3)).delivered, 1U);
  ASSERT_EQ(foreign->payloads().size(), 1U);
  EXPECT_EQ(foreign->payloads()[0], wire.expected);
}

INSTANTIATE_TEST_SUITE_P(Wire, ForeignInPortBytes,
                         ::testing::Values(WireCase{"big", true, kBig}, WireCase{"little", true, kLittle},
                                           WireCase{"", true, kLittle}, WireCase{"big", false, kBig},
                                           WireCase{" big , little", true, kBig}));

TEST(ForeignInPort, EachConnectionGetsItsOwnByteOrderFromOneWrite) {
  ForeignInPort little;
  ForeignInPort big;
  Writer<RTC::TimedPose2D> out("pose");
  // Both connections list only the OutPort, which would make the second a duplicate.
  const auto allow_dup = std::pair<std::string, std::string>{"dataport.allow_dup_connection", "YES"};
  ASSERT_EQ(connect({&out}, with(little.published(), {{"dataport.serializer.cdr.endian", "little"}, allow_dup})).code,
            RTC::RTC_OK);
  ASSERT_EQ(connect({&out}, with(big.published(), {{"dataport.serializer.cdr.endian", "big"}, allow_dup})).code,
            RTC::RTC_OK);
  EXPECT_EQ(out.write(timed_pose(1, 0.5, 0, 0)).delivered, 2U);

  ASSERT_EQ(little->payloads().size(), 1U);
  ASSERT_EQ(big->payloads().size(), 1U);
  const Bytes le = little->payloads()[0];
  const Bytes be = big->payloads()[0];
  ASSERT_EQ(le.size(), 32U);  // tm 8, x 8, y 8, heading 8
  ASSERT_EQ(be.size(), 32U);
  EXPECT_EQ(Bytes(le.begin(), le.begin() + 4), (Bytes{1, 0, 0, 0}));
  EXPECT_EQ(Bytes(be.begin(), be.begin() + 4), (Bytes{0, 0, 0, 1}));
  // 0.5 is 0x3fe0000000000000
  EXPECT_EQ(Bytes(le.begin() + 8, le.begin() + 16), (Bytes{0, 0, 0, 0, 0, 0, 0xe0, 0x3f}));
  EXPECT_EQ(Bytes(be.begin() + 8, be.begin() + 16), (Bytes{0x3f, 0xe0, 0, 0, 0, 0, 0, 0}));
}

TEST(ForeignInPort, BufferFullIsCountedAndTheConnectionKept) {
  ForeignInPort foreign;
  foreign->answer(OpenRTM::BUFFER_FULL);
  Writer<RTC::TimedLong> out("count");
  ASSERT_EQ(connect({&out}, foreign.published()).code, RTC::RTC_OK);
  for (int i = 0; i < 3; ++i) {
    const auto result = out.write(timed_long(0, 0, i));
    EXPECT_EQ(result.delivered, 0U);
    EXPECT_EQ(result.refused, 1U);
    EXPECT_EQ(result.dropped, 0U);
  }
  foreign->answer(OpenRTM::PORT_OK);
  EXPECT_EQ(out.write(timed_long(0, 0, 3)).delivered, 1U);
  EXPECT_EQ(out.connection_count(), 1U);
  const auto stats = out.connector_stats();
  ASSERT_EQ(stats.size(), 1U);
  EXPECT_EQ(stats[0].refused, 3U);
  EXPECT_EQ(stats[0].sent, 1U);
  EXPECT_EQ(stats[0].last_status, OpenRTM::PORT_OK);
}

TEST(ForeignInPort, MissingInPortCdrRefusesTheConnection) {
  Writer<RTC::TimedLong> out("count");
  EXPECT_NE(connect({&out}).code, RTC::RTC_OK);
  EXPECT_EQ(out.connection_count(), 0U);
}

// ---- a foreign OutPort to our InPort ----

// Connects `in` alone, as a foreign OutPort's connect would, and returns the InPortCdr it published.
OpenRTM::InPortCdr_ptr published_inport(rtc::InPort<RTC::TimedLong>& in, const char* endian) {
  const auto connection = connect(
      {&in}, properties({{"dataport.serializer.cdr.endian", endian}, {"dataport.data_type", "IDL:RTC/TimedLong:1.0"}}));
  EXPECT_EQ(connection.code, RTC::RTC_OK);
  CORBA::Object_var object = rtc::nv_object(connection.profile.properties, "dataport.corba_cdr.inport_ref");
  const auto ior = rtc::nv_string(connection.profile.properties, "dataport.corba_cdr.inport_ior");
  EXPECT_TRUE(ior && ior->rfind("IOR:", 0) == 0);
  if (ior) {
    CORBA::Object_var from_ior = the_orb->string_to_object(*ior);
    EXPECT_TRUE(from_ior->_is_equivalent(object));
  }
  return OpenRTM::InPortCdr::_narrow(object);
}

TEST(ForeignOutPort, HandMadeBigEndianBytesAreDecoded) {
  Reader<RTC::TimedLong> in("count");
  OpenRTM::InPortCdr_var inport = published_inport(in, "big");
  ASSERT_FALSE(CORBA::is_nil(inport));
  EXPECT_EQ(inport->put(cdr_data({0, 0, 0, 1, 0, 0, 0, 2, 0xff, 0xff, 0xff, 0xfb})), OpenRTM::PORT_OK);
  const auto value = in.latest();
  ASSERT_TRUE(value);
  EXPECT_EQ(value->tm.sec, 1U);
  EXPECT_EQ(value->tm.nsec, 2U);
  EXPECT_EQ(value->data, -5);
}

TEST(ForeignOutPort, AMalformedPayloadIsRefusedAndThePortKeepsWorking) {
  Reader<RTC::TimedLong> in("count");
  OpenRTM::InPortCdr_var inport = published_inport(in, "little");
  ASSERT_FALSE(CORBA::is_nil(inport));
  Bytes good = timed_long_cdr(1, 2, 42, false);
  Bytes truncated(good.begin(), good.end() - 1);
  Bytes too_long = good;
  too_long.push_back(0);
  EXPECT_EQ(inport->put(cdr_data(truncated)), OpenRTM::PORT_ERROR);
  EXPECT_EQ(inport->put(cdr_data({})), OpenRTM::PORT_ERROR);
  EXPECT_EQ(inport->put(cdr_data(too_long)), OpenRTM::PORT_ERROR);
  EXPECT_EQ(in.rejected(), 3U);
  EXPECT_EQ(in.received(), 0U);
  EXPECT_FALSE(in.is_new());

  EXPECT_EQ(inport->put(cdr_data(good)), OpenRTM::PORT_OK);
  RTC::TimedLong value;
  ASSERT_TRUE(in.read(value));
  EXPECT_EQ(value.data, 42);
  EXPECT_EQ(in.received(), 1U);
}

TEST(ForeignOutPort, APayloadNotOnAnEightByteBoundaryDecodes) {
  Reader<RTC::TimedPose2D> in("pose");
  const auto connection = connect({&in}, properties({{"dataport.serializer.cdr.endian", "big"}}));
  ASSERT_EQ(connection.code, RTC::RTC_OK);
  CORBA::Object_var object = rtc::nv_object(connection.profile.properties, "dataport.corba_cdr.inport_ref");
  OpenRTM::InPortCdr_var inport = OpenRTM::InPortCdr::_narrow(object);
  ASSERT_FALSE(CORBA::is_nil(inport));

  cdrMemoryStream stream;
  stream.setByteSwapFlag(false);
  timed_pose(9, -1.25, 4.5, 0.125) >>= stream;
  // In process the call hands over this very buffer: one byte in, the doubles are misaligned.
  std::vector<std::uint64_t> storage(stream.bufSize() / 8 + 2);
  auto* shifted = reinterpret_cast<CORBA::Octet*>(storage.data()) + 1;
  std::memcpy(shifted, stream.bufPtr(), stream.bufSize());
  const OpenRTM::CdrData view(stream.bufSize(), stream.bufSize(), shifted, false);
  EXPECT_EQ(inport->put(view), OpenRTM::PORT_OK);
  const auto pose = in.latest();
  ASSERT_TRUE(pose);
  EXPECT_EQ(pose->tm.sec, 9U);
  EXPECT_EQ(pose->data.position.x, -1.25);
  EXPECT_EQ(pose->data.position.y, 4.5);
  EXPECT_EQ(pose->data.heading, 0.125);
}

TEST(ForeignOutPort, DisconnectingRetiresThePublishedInPortCdr) {
  Reader<RTC::TimedLong> in("count");
  OpenRTM::InPortCdr_var inport = published_inport(in, "little");
  ASSERT_FALSE(CORBA::is_nil(inport));
  EXPECT_EQ(in.disconnect_all(), RTC::RTC_OK);
  EXPECT_EQ(in.connection_count(), 0U);
  EXPECT_THROW(inport->put(cdr_data(timed_long_cdr(0, 0, 1, false))), CORBA::OBJECT_NOT_EXIST);
}

// ---- subscription new ----

TEST(SubscriptionNew, TheSenderSkipsToTheNewestValue) {
  Writer<RTC::TimedLong> out("count");
  Reader<RTC::TimedLong> in("count");

  // The reader holds the first value until told, so later writes pile up behind it.
  struct Gate {
    std::mutex mutex;
    std::condition_variable changed;
    bool entered = false;
    bool open = false;
    void release() {
      std::lock_guard lock(mutex);
      open = true;
      changed.notify_all();
    }
    ~Gate() { release(); }
  } gate;
  in.on_receive([&gate](const RTC::TimedLong& value) {
    if (value.data != 1) return;
    std::unique_lock lock(gate.mutex);
    gate.entered = true;
    gate.changed.notify_all();
    gate.changed.wait(lock, [&gate] { return gate.open; });
  });
  ASSERT_EQ(connect({&out, &in}, properties({{"dataport.subscription_type", "new"}})).code, RTC::RTC_OK);

  EXPECT_EQ(out.write(timed_long(0, 0, 1)).delivered, 1U);
  {
    std::unique_lock lock(gate.mutex);
    ASSERT_TRUE(gate.changed.wait_for(lock, 5s, [&gate] { return gate.entered; }));
  }
  for (CORBA::Long i = 2; i <= 5; ++i) EXPECT_EQ(out.write(timed_long(0, 0, i)).delivered, 1U);
  gate.release();

  ASSERT_TRUE(wait_until([&] { return in.received() == 2; }, 5s));
  std::vector<CORBA::Long> read;
  for (RTC::TimedLong value; in.read(value);) read.push_back(value.data);
  EXPECT_EQ(read, (std::vector<CORBA::Long>{1, 5}));
  ASSERT_TRUE(wait_until([&] { return out.connector_stats().at(0).sent == 2; }, 5s));
  const auto stats = out.connector_stats().at(0);
  EXPECT_EQ(stats.subscription, rtc::Subscription::kNew);
  EXPECT_EQ(stats.skipped, 3U);
}

// ---- dead peers ----

TEST(DeadPeer, AFlushConnectionIsDroppedOnTheNextWriteAndTheOthersGoOn) {
  ForeignInPort foreign;
  Writer<RTC::TimedLong> out("count");
  Reader<RTC::TimedLong> in("count");
  ASSERT_EQ(connect({&out, &in}).code, RTC::RTC_OK);
  ASSERT_EQ(connect({&out}, foreign.published()).code, RTC::RTC_OK);
  EXPECT_EQ(out.write(timed_long(0, 0, 1)).delivered, 2U);

  foreign.die();
  const auto result = out.write(timed_long(0, 0, 2));
  EXPECT_EQ(result.delivered, 1U);
  EXPECT_EQ(result.dropped, 1U);
  EXPECT_EQ(out.connection_count(), 1U);
  const auto next = out.write(timed_long(0, 0, 3));
  EXPECT_EQ(next.delivered, 1U);
  EXPECT_EQ(next.dropped, 0U);
  EXPECT_EQ(in.received(), 3U);
}

TEST(DeadPeer, ANewConnectionIsDroppedOnceItsSenderFindsThePeerGone) {
  ForeignInPort foreign;
  Writer<RTC::TimedLong> out("count");
  ASSERT_EQ(connect({&out}, with(foreign.published(), {{"dataport.subscription_type", "new"}})).code, RTC::RTC_OK);
  foreign.die();
  std::size_t dropped = 0;
  EXPECT_TRUE(wait_until([&] { return (dropped += out.write(timed_long(0, 0, 1)).dropped) > 0; }, 5s));
  EXPECT_EQ(dropped, 1U);
  EXPECT_EQ(out.connection_count(), 0U);
}

// ---- refused connections ----

TEST(Duplicates, ASecondConnectionBetweenTheSamePortsNeedsAllowDupConnection) {
  Writer<RTC::TimedLong> out("count");
  Reader<RTC::TimedLong> in("count");
  ASSERT_EQ(connect({&out, &in}).code, RTC::RTC_OK);
  EXPECT_NE(connect({&out, &in}).code, RTC::RTC_OK);
  EXPECT_EQ(out.connection_count(), 1U);
  EXPECT_EQ(in.connection_count(), 1U);

  ASSERT_EQ(connect({&out, &in}, properties({{"dataport.allow_dup_connection", "YES"}})).code, RTC::RTC_OK);
  EXPECT_EQ(out.connection_count(), 2U);
  EXPECT_EQ(out.write(timed_long(0, 0, 1)).delivered, 2U);
  EXPECT_EQ(in.received(), 2U);
}

TEST(Refused, APortOfAnotherDataType) {
  Writer<RTC::TimedLong> out("count");
  Reader<RTC::TimedPose2D> in("pose");
  EXPECT_EQ(connect({&out, &in}).code, RTC::BAD_PARAMETER);
  EXPECT_EQ(connect({&in, &out}).code, RTC::BAD_PARAMETER);
  EXPECT_EQ(out.connection_count(), 0U);
  EXPECT_EQ(in.connection_count(), 0U);
}

TEST(Refused, ConnectorPropertiesThePortsDoNotSupport) {
  Writer<RTC::TimedLong> out("count");
  Reader<RTC::TimedLong> in("count");
  const std::pair<std::string, std::string> unsupported[] = {
      {"dataport.data_type", "IDL:RTC/TimedShort:1.0"},
      {"dataport.subscription_type", "periodic"},
      {"dataport.serializer.cdr.endian", "middle"},
      {"dataport.interface_type", "shared_memory"},
      {"dataport.dataflow_type", "pull"},
      {"dataport.marshaling_type", "json"},
  };
  for (const auto& property : unsupported) {
    EXPECT_EQ(connect({&out, &in}, properties({property})).code, RTC::BAD_PARAMETER) << property.first;
  }
  EXPECT_EQ(out.connection_count(), 0U);
  EXPECT_EQ(in.connection_count(), 0U);
}

TEST(Accepted, OpenRtm1StyleDataTypeAndMarshalingNames) {
  Writer<RTC::TimedLong> out("count");
  Reader<RTC::TimedLong> in("count");
  const auto extra = properties({{"dataport.data_type", "TimedLong"},
                                 {"dataport.marshaling_type", "corba"},
                                 {"dataport.allow_dup_connection", "YES"}});
  ASSERT_EQ(connect({&out, &in}, extra).code, RTC::RTC_OK);
  const auto cdr = properties({{"dataport.marshaling_type", "cdr"}, {"dataport.allow_dup_connection", "YES"}});
  ASSERT_EQ(connect({&out, &in}, cdr).code, RTC::RTC_OK);
  EXPECT_EQ(out.write(timed_long(0, 0, 1)).delivered, 2U);
}

}  // namespace
}  // namespace urs::test
