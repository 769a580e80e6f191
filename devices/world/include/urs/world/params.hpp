#pragma once
// Reading a simulated device's `params` map (from a urs-sam or urs-rtc-manager config) so that a
// user sees every mistake at once: each reader records "<device>.<key>: <what is wrong>", and
// finish() throws one urs::util::ConfigError listing them all.

#include <yaml-cpp/yaml.h>

#include <cstdint>
#include <set>
#include <string>
#include <vector>

namespace urs::world {

class DeviceParams {
 public:
  // Records an error if `params` is neither null nor a map, or has a key not in `allowed`.
  DeviceParams(const YAML::Node& params, std::string device, const std::set<std::string>& allowed);

  // The key's value, or `fallback` if absent; records an error naming the key if it is not a
  // number within [min, max] (NaN is never within).
  double number(const std::string& key, double fallback, double min, double max);
  std::string text(const std::string& key, const std::string& fallback);  // records an error if empty
  // The key's value, or `fallback` if absent; records an error if it is not one of `allowed`.
  std::string choice(const std::string& key, const std::string& fallback, const std::set<std::string>& allowed);
  uint32_t domain();  // key "domain": a DDS domain id, 0 .. 232, default 0

  // Throws urs::util::ConfigError "params of <device> has N error(s): ..." if any was recorded.
  void finish() const;

 private:
  YAML::Node params_;
  std::string device_;
  std::vector<std::string> errors_;
};

}  // namespace urs::world
