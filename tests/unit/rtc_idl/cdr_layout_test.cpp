// CDR layouts of urs::rtc_idl data types as OpenRTM-aist's CORBA_CDR data ports carry them: the
// raw CDR of the struct, aligned from offset 0, no encapsulation octet (docs/rtc.md).
#include <gtest/gtest.h>
#include <omniORB4/CORBA.h>

#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "BasicDataType.hh"
#include "ExtendedDataTypes.hh"
#include "SDOPackage.hh"

namespace {

// Strings in a cdrMemoryStream need the ORB's code-set converters, which ORB_init installs.
class RtcIdlCdr : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    int argc = 0;
    orb_ = CORBA::ORB_init(argc, nullptr);
  }
  static void TearDownTestSuite() {
    orb_->destroy();
    CORBA::release(orb_);
    orb_ = CORBA::ORB::_nil();
  }

 private:
  static CORBA::ORB_ptr orb_;
};

CORBA::ORB_ptr RtcIdlCdr::orb_ = CORBA::ORB::_nil();

std::vector<std::uint8_t> Bytes(cdrMemoryStream& stream) {
  const auto* begin = static_cast<const std::uint8_t*>(stream.bufPtr());
  return std::vector<std::uint8_t>(begin, begin + stream.bufSize());
}

RTC::TimedLong SampleTimedLong() {
  RTC::TimedLong value;
  value.tm.sec = 0x01020304U;
  value.tm.nsec = 0x05060708U;
  value.data = -2;  // 0xfffffffe
  return value;
}

TEST_F(RtcIdlCdr, TimedLongIsTwelveLittleEndianBytesFromOffsetZero) {
  cdrMemoryStream stream;
  stream.setByteSwapFlag(true);  // little-endian, whatever the host
  SampleTimedLong() >>= stream;
  const std::vector<std::uint8_t> expected = {0x04, 0x03, 0x02, 0x01,   // tm.sec
                                              0x08, 0x07, 0x06, 0x05,   // tm.nsec
                                              0xfe, 0xff, 0xff, 0xff};  // data
  EXPECT_EQ(Bytes(stream), expected);

  RTC::TimedLong back;
  stream.rewindInputPtr();
  back <<= stream;
  EXPECT_EQ(back.tm.sec, 0x01020304U);
  EXPECT_EQ(back.tm.nsec, 0x05060708U);
  EXPECT_EQ(back.data, -2);
}

TEST_F(RtcIdlCdr, TimedLongBigEndianWhenTheConnectorAsksForIt) {
  cdrMemoryStream stream;
  stream.setByteSwapFlag(false);  // big-endian
  SampleTimedLong() >>= stream;
  const std::vector<std::uint8_t> expected = {0x01, 0x02, 0x03, 0x04, 0x05, 0x06, 0x07, 0x08, 0xff, 0xff, 0xff, 0xfe};
  EXPECT_EQ(Bytes(stream), expected);
}

TEST_F(RtcIdlCdr, CameraImageFieldOrderAndPadding) {
  RTC::CameraImage image;
  image.tm.sec = 1;
  image.tm.nsec = 2;
  image.width = 3;
  image.height = 4;
  image.bpp = 24;
  image.format = CORBA::string_dup("rgb");
  image.fDiv = 1.0;
  image.pixels.length(2);
  image.pixels[0] = 0xaa;
  image.pixels[1] = 0xbb;

  cdrMemoryStream stream;
  stream.setByteSwapFlag(true);
  image >>= stream;
  const std::vector<std::uint8_t> bytes = Bytes(stream);
  // tm 0..7, width 8, height 10, bpp 12, pad 14..15, format length 16 + "rgb\0" 20..23,
  // fDiv aligned to 8 at 24..31, pixels length 32..35, pixels 36..37.
  ASSERT_EQ(bytes.size(), 38U);
  EXPECT_EQ(bytes[8], 3);
  EXPECT_EQ(bytes[10], 4);
  EXPECT_EQ(bytes[12], 24);
  EXPECT_EQ(bytes[16], 4);  // string length including the terminating NUL
  EXPECT_EQ(std::string(reinterpret_cast<const char*>(&bytes[20])), "rgb");
  double fdiv = 0.0;
  std::memcpy(&fdiv, &bytes[24], sizeof fdiv);  // the test host is little-endian (x86-64/arm64)
  EXPECT_EQ(fdiv, 1.0);
  EXPECT_EQ(bytes[32], 2);
  EXPECT_EQ(bytes[36], 0xaa);
  EXPECT_EQ(bytes[37], 0xbb);
}

TEST_F(RtcIdlCdr, NvListWithStringAnyRoundTrips) {
  SDOPackage::NVList list;
  list.length(2);
  list[0].name = CORBA::string_dup("dataport.data_type");
  list[0].value <<= "IDL:RTC/TimedLong:1.0";
  list[1].name = CORBA::string_dup("dataport.buffer.length");
  list[1].value <<= static_cast<CORBA::Long>(8);

  cdrMemoryStream stream;
  list >>= stream;
  SDOPackage::NVList back;
  stream.rewindInputPtr();
  back <<= stream;

  ASSERT_EQ(back.length(), 2U);
  EXPECT_STREQ(back[0].name, "dataport.data_type");
  const char* text = nullptr;
  ASSERT_TRUE(back[0].value >>= text);
  EXPECT_STREQ(text, "IDL:RTC/TimedLong:1.0");
  EXPECT_TRUE(back[0].value.type()->equivalent(CORBA::_tc_string));
  EXPECT_STREQ(back[1].name, "dataport.buffer.length");
  CORBA::Long number = 0;
  ASSERT_TRUE(back[1].value >>= number);
  EXPECT_EQ(number, 8);
}

}  // namespace
