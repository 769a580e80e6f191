#pragma once
// Reads a device's `params` map so that every mistake is reported at once: each reader appends
// "<key>: <what is wrong>" and finish() throws one urs::util::ConfigError listing them.

#include <yaml-cpp/yaml.h>

#include <set>
#include <string>
#include <vector>

namespace urs::devices {

class ParamReader {
 public:
  // `device` names the device in the error ("tts params: ..."). A null node is an empty map.
  ParamReader(std::string device, const YAML::Node& params, const std::set<std::string>& allowed);

  // Each leaves `out` unchanged when the key is absent or its value is bad.
  void text(const std::string& key, std::string& out);
  void nonempty_text(const std::string& key, std::string& out);
  template <class Int>
  void integer(const std::string& key, long min, long max, Int& out) {
    long value = static_cast<long>(out);
    read_integer(key, min, max, value);
    out = static_cast<Int>(value);
  }
  void number(const std::string& key, double min, double max, double& out);
  void text_list(const std::string& key, std::vector<std::string>& out);

  void fail(const std::string& key, const std::string& what);
  void finish() const;  // throws urs::util::ConfigError if anything failed

 private:
  void read_integer(const std::string& key, long min, long max, long& out);

  std::string device_;
  YAML::Node params_;
  std::vector<std::string> errors_;
};

}  // namespace urs::devices
