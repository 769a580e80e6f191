#include "urs/rtc/data_port.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cctype>
#include <utility>
#include <vector>

#include "data_port_detail.hpp"
#include "urs/rtc/nvlist.hpp"

namespace urs::rtc {
namespace {

std::string trimmed_lower(const std::string& text) {
  const auto first = text.find_first_not_of(" \t");
  if (first == std::string::npos) return {};
  const auto last = text.find_last_not_of(" \t");
  std::string result = text.substr(first, last - first + 1);
  std::transform(result.begin(), result.end(), result.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return result;
}

}  // namespace

namespace data_port_detail {

std::string setting(const RTC::ConnectorProfile& profile, const std::string& name) {
  return trimmed_lower(nv_string(profile.properties, name).value_or(""));
}

bool worth_logging(std::uint64_t count) {
  while (count >= 10 && count % 10 == 0) count /= 10;
  return count == 1;
}

const char* order_name(ByteOrder order) { return order == ByteOrder::kLittle ? "little" : "big"; }

}  // namespace data_port_detail

using data_port_detail::setting;

std::optional<ByteOrder> parse_byte_order(const std::string& list) {
  const std::string first = trimmed_lower(list.substr(0, list.find(',')));
  if (first.empty() || first == "little") return ByteOrder::kLittle;
  if (first == "big") return ByteOrder::kBig;
  return std::nullopt;
}

std::optional<Subscription> parse_subscription(const std::string& text) {
  const std::string value = trimmed_lower(text);
  if (value.empty() || value == "flush") return Subscription::kFlush;
  if (value == "new") return Subscription::kNew;
  return std::nullopt;
}

bool data_type_matches(const std::string& repository_id, const std::string& connector_data_type) {
  if (connector_data_type == repository_id) return true;
  // "IDL:RTC/TimedLong:1.0" -> "TimedLong"
  const auto version = repository_id.rfind(':');
  if (version == std::string::npos || version == 0) return false;
  const auto scope = repository_id.find_last_of("/:", version - 1);
  if (scope == std::string::npos) return false;
  return connector_data_type == repository_id.substr(scope + 1, version - scope - 1);
}

DataPort::DataPort(std::string name, std::string port_type, std::string data_type)
    : PortBase(std::move(name), std::move(port_type)), data_type_(std::move(data_type)) {
  set_property("dataport.data_type", data_type_);
  set_property("dataport.interface_type", "corba_cdr");
  set_property("dataport.dataflow_type", "push");
  set_property("dataport.subscription_type", "flush,new");
}

std::optional<ByteOrder> DataPort::connector_byte_order(const RTC::ConnectorProfile& profile) const {
  const std::string id = profile.connector_id.in();
  const auto refuse = [&](const char* property, const std::string& value) -> std::optional<ByteOrder> {
    spdlog::warn("port {}: connection {} refused: {}={} is not supported", name(), id, property, value);
    return std::nullopt;
  };
  const std::pair<const char*, std::vector<std::string>> accepted[] = {
      {"dataport.interface_type", {"corba_cdr"}},
      {"dataport.dataflow_type", {"push"}},
      {"dataport.marshaling_type", {"cdr", "corba"}},
  };
  for (const auto& [property, values] : accepted) {
    const std::string value = setting(profile, property);
    if (!value.empty() && std::find(values.begin(), values.end(), value) == values.end()) {
      return refuse(property, value);
    }
  }
  const auto data_type = nv_string(profile.properties, "dataport.data_type");
  if (data_type && !data_type_matches(data_type_, *data_type)) {
    spdlog::warn("port {}: connection {} refused: dataport.data_type={} but this port carries {}", name(), id,
                 *data_type, data_type_);
    return std::nullopt;
  }
  const std::string endian = setting(profile, "dataport.serializer.cdr.endian");
  const auto order = parse_byte_order(endian);
  if (!order) return refuse("dataport.serializer.cdr.endian", endian);
  return order;
}

}  // namespace urs::rtc
