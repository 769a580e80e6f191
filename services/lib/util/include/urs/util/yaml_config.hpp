#pragma once
// Reading YAML configuration files so that a user sees every mistake at once: each helper
// appends "<where>: <what is wrong>" to an error list, and throw_if_errors() turns the list into
// one urs::util::ConfigError naming the file.

#include <yaml-cpp/yaml.h>

#include <set>
#include <string>
#include <vector>

namespace urs::util {

// The parsed file; ConfigError if it cannot be read or is not YAML. `flag` names the option
// that gave the path (e.g. "--config").
YAML::Node load_yaml_file(const std::string& path, const std::string& flag);

std::string join(const std::set<std::string>& items);  // "a, b, c"

// `node` as T; on failure appends "<where>: '<value>' is not a valid value" and returns false.
template <class T>
bool read_scalar(const YAML::Node& node, const std::string& where, T& out, std::vector<std::string>& errors) {
  try {
    out = node.as<T>();
    return true;
  } catch (const YAML::Exception&) {
    errors.push_back(where + ": '" + YAML::Dump(node) + "' is not a valid value");
    return false;
  }
}

// Appends an error for every key of the map `node` not in `allowed`.
void check_keys(const YAML::Node& node, const std::string& where, const std::set<std::string>& allowed,
                std::vector<std::string>& errors);

// ConfigError "<flag> '<path>' has N error(s):" with one error per line, if there are any.
void throw_if_errors(const std::vector<std::string>& errors, const std::string& path, const std::string& flag);

}  // namespace urs::util
