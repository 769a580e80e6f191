#pragma once
// What data_port.cpp, out_port.cpp and in_port.cpp share (urs/rtc/data_port.hpp): the connector
// properties under which an InPort publishes its InPortCdr, reading a connector setting as
// OpenRTM-aist compares it, and the helpers of their log lines. Functions of their arguments
// only: any thread.

#include <cstdint>
#include <string>

#include "RTC.hh"
#include "urs/rtc/data_port.hpp"

namespace urs::rtc::data_port_detail {

inline constexpr const char* kInPortIor = "dataport.corba_cdr.inport_ior";
inline constexpr const char* kInPortRef = "dataport.corba_cdr.inport_ref";

// A connector property as OpenRTM-aist compares it: trimmed, lower case; "" if absent.
std::string setting(const RTC::ConnectorProfile& profile, const std::string& name);

// A peer that misbehaves on every call would flood the log; the 1st, 10th, 100th... are enough
// to show that it goes on.
bool worth_logging(std::uint64_t count);

const char* order_name(ByteOrder order);

}  // namespace urs::rtc::data_port_detail
