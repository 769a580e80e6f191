// How data ports read the connector properties OpenRTM-aist tools write, and which repository ID
// a port reports for its type.
#include <gtest/gtest.h>

#include "BasicDataType.hh"
#include "ExtendedDataTypes.hh"
#include "urs/rtc/data_port.hpp"

namespace urs::rtc {
namespace {

TEST(ByteOrderSetting, TheFirstEntryOfTheListWins) {
  EXPECT_EQ(parse_byte_order("little,big"), ByteOrder::kLittle);
  EXPECT_EQ(parse_byte_order("big,little"), ByteOrder::kBig);
  EXPECT_EQ(parse_byte_order("big"), ByteOrder::kBig);
  EXPECT_EQ(parse_byte_order(" Big , little"), ByteOrder::kBig);
}

TEST(ByteOrderSetting, EmptyMeansLittle) {
  EXPECT_EQ(parse_byte_order(""), ByteOrder::kLittle);
  EXPECT_EQ(parse_byte_order("  "), ByteOrder::kLittle);
}

TEST(ByteOrderSetting, AnUnknownFirstEntryIsRefused) {
  EXPECT_EQ(parse_byte_order("middle"), std::nullopt);
  EXPECT_EQ(parse_byte_order("middle,big"), std::nullopt);
}

TEST(SubscriptionSetting, FlushNewOrRefused) {
  EXPECT_EQ(parse_subscription(""), Subscription::kFlush);
  EXPECT_EQ(parse_subscription("flush"), Subscription::kFlush);
  EXPECT_EQ(parse_subscription("New"), Subscription::kNew);
  EXPECT_EQ(parse_subscription("periodic"), std::nullopt);
}

TEST(DataTypeSetting, TheRepositoryIdOrTheBareTypeName) {
  EXPECT_TRUE(data_type_matches("IDL:RTC/TimedLong:1.0", "IDL:RTC/TimedLong:1.0"));
  EXPECT_TRUE(data_type_matches("IDL:RTC/TimedLong:1.0", "TimedLong"));
  EXPECT_FALSE(data_type_matches("IDL:RTC/TimedLong:1.0", "IDL:RTC/TimedShort:1.0"));
  EXPECT_FALSE(data_type_matches("IDL:RTC/TimedLong:1.0", "TimedShort"));
  EXPECT_FALSE(data_type_matches("IDL:RTC/TimedLong:1.0", "RTC/TimedLong"));
  EXPECT_FALSE(data_type_matches("IDL:RTC/TimedLong:1.0", ""));
  EXPECT_TRUE(data_type_matches("IDL:Plain:1.0", "Plain"));
}

TEST(RepositoryId, ComesFromTheTypeCodeOmniidlGenerated) {
  EXPECT_EQ(repository_id<RTC::TimedLong>(), "IDL:RTC/TimedLong:1.0");
  EXPECT_EQ(repository_id<RTC::TimedPose2D>(), "IDL:RTC/TimedPose2D:1.0");
  EXPECT_EQ(repository_id<RTC::CameraImage>(), "IDL:RTC/CameraImage:1.0");
}

}  // namespace
}  // namespace urs::rtc
