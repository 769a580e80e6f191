#include "urs/world/params.hpp"

#include <cmath>
#include <sstream>

#include "urs/util/cli.hpp"
#include "urs/util/yaml_config.hpp"

namespace urs::world {

DeviceParams::DeviceParams(const YAML::Node& params, std::string device, const std::set<std::string>& allowed)
    : params_(params), device_(std::move(device)) {
  if (!params_ || params_.IsNull()) {
    params_ = YAML::Node(YAML::NodeType::Map);
  } else if (!params_.IsMap()) {
    errors_.push_back(device_ + ": params must be a map (keys: " + util::join(allowed) + ")");
    params_ = YAML::Node(YAML::NodeType::Map);
  } else {
    util::check_keys(params_, device_, allowed, errors_);
  }
}

double DeviceParams::number(const std::string& key, double fallback, double min, double max) {
  const YAML::Node node = params_[key];
  if (!node) return fallback;
  double value = fallback;
  if (!util::read_scalar(node, device_ + "." + key, value, errors_)) return fallback;
  if (!(value >= min && value <= max)) {
    std::ostringstream out;
    out << device_ << "." << key << ": " << value << " is outside " << min << " .. " << max;
    errors_.push_back(out.str());
    return fallback;
  }
  return value;
}

std::string DeviceParams::text(const std::string& key, const std::string& fallback) {
  const YAML::Node node = params_[key];
  if (!node) return fallback;
  std::string value;
  if (!util::read_scalar(node, device_ + "." + key, value, errors_)) return fallback;
  if (value.empty()) {
    errors_.push_back(device_ + "." + key + ": must not be empty");
    return fallback;
  }
  return value;
}

std::string DeviceParams::choice(const std::string& key, const std::string& fallback,
                                 const std::set<std::string>& allowed) {
  const std::string value = text(key, fallback);
  if (allowed.count(value) == 0) {
    errors_.push_back(device_ + "." + key + ": '" + value + "' is not one of " + util::join(allowed));
    return fallback;
  }
  return value;
}

uint32_t DeviceParams::domain() {
  // 232 is the highest domain id whose RTPS ports still fit in 16 bits with Fast DDS's defaults.
  const double id = number("domain", 0, 0, 232);
  if (id != std::floor(id)) {
    errors_.push_back(device_ + ".domain: must be a whole number");
    return 0;
  }
  return static_cast<uint32_t>(id);
}

void DeviceParams::finish() const { util::throw_if_errors(errors_, "params of " + device_); }

}  // namespace urs::world
