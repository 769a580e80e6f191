#pragma once
// One reader for a device's `params` map (the `params:` of its entry in a urs-sam or
// urs-rtc-manager config), shared by every device of devices/:
//
//   ParamReader p("robot", params, {"name", "speed", "feedback"});
//   config.name = p.text("name", config.name);
//   config.speed = p.number("speed", config.speed, 0, 1200);
//   p.finish();   // throws ParamError listing every mistake
//
// Every mistake is recorded, not thrown at once, so a user sees them all: keys the device does not
// know, values of the wrong kind, values outside their range. Each names its key as a path inside
// `params` ("speed", "camera.width", "markers[2].id"). A reader returns the fallback for an absent
// or wrong key, so the device can go on reading the rest.

#include <yaml-cpp/yaml.h>

#include <cstdint>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "urs/util/cli.hpp"

namespace urs::devices {

// One mistake: the key path inside `params` ("" for params itself) and what is wrong with it.
struct ParamProblem {
  std::string key;
  std::string what;
  bool operator==(const ParamProblem& other) const { return key == other.key && what == other.what; }
};

// A device refused its params. what() is "<device> params: N error(s):" with one line
// "  <key>: <what>" per problem. A urs::util::ConfigError, so hosts report it as any other
// configuration mistake.
class ParamError : public util::ConfigError {
 public:
  ParamError(std::string device, std::vector<ParamProblem> problems);
  const std::string& device() const noexcept { return device_; }
  const std::vector<ParamProblem>& problems() const noexcept { return problems_; }

 private:
  std::string device_;
  std::vector<ParamProblem> problems_;
};

class ParamReader {
 public:
  // `params` null or absent: every key takes its fallback. Not a map: the problem "params: must be
  // a map (keys: ...)". Every key not in `allowed`: "<key>: unknown key (allowed: ...)".
  ParamReader(std::string device, const YAML::Node& params, const std::set<std::string>& allowed);

  bool has(const std::string& key) const;  // present (even if wrong)

  // Each returns the key's value, or `fallback` when the key is absent or its value wrong (a
  // problem is then recorded).
  // A finite number within [min, max] ("'5000' is outside 0 .. 1200", "'.nan' is not a number").
  double number(const std::string& key, double fallback, double min, double max);
  // A whole number within [min, max] (exact up to 2^53).
  template <class Int>
  Int integer(const std::string& key, Int fallback, Int min, Int max) {
    const auto value = whole_number(key, static_cast<double>(min), static_cast<double>(max));
    return value ? static_cast<Int>(*value) : fallback;
  }
  std::string text(const std::string& key, const std::string& fallback);  // a non-empty string
  // text() that must be one of `allowed` ("'gps' is not one of ground_truth, localizer").
  std::string choice(const std::string& key, const std::string& fallback, const std::set<std::string>& allowed);
  // A non-empty list of non-empty strings.
  std::vector<std::string> text_list(const std::string& key, const std::vector<std::string>& fallback);
  // A DDS domain id, 0 .. 232 (the highest id whose RTPS ports fit in 16 bits with Fast DDS's
  // defaults).
  uint32_t domain(const std::string& key, uint32_t fallback);

  // The map at `key` read with its own allowed keys; its problems are this reader's, named
  // "<key>.<inner key>". nullopt when absent, or when not a map (a problem is recorded).
  std::optional<ParamReader> section(const std::string& key, const std::set<std::string>& allowed);
  // Every element of the list at `key` as a section named "<key>[i]"; an element that is not a map
  // is a problem and skipped, as is a `key` that is not a list. Empty when absent.
  std::vector<ParamReader> sections(const std::string& key, const std::set<std::string>& allowed);

  // Records a problem the device found itself (a rule between keys, a value no range expresses);
  // `key` is relative to this reader's section, "" for the section itself.
  void fail(const std::string& key, const std::string& what);
  bool failed() const;  // any problem recorded so far, in any section
  // Throws ParamError with every problem recorded, in any section, if there is one.
  void finish() const;

 private:
  struct Problems;
  ParamReader(std::shared_ptr<Problems> problems, YAML::Node node, std::string path);
  std::string path_of(const std::string& key) const;
  void check_keys(const std::set<std::string>& allowed);
  // The key's value as text if it is a scalar; a problem "must be <kind>" otherwise.
  std::optional<std::string> scalar(const std::string& key, const char* kind);
  std::optional<double> whole_number(const std::string& key, double min, double max);

  std::shared_ptr<Problems> problems_;
  YAML::Node node_;   // always a map
  std::string path_;  // "" for params itself, "camera", "markers[0]"
};

}  // namespace urs::devices
