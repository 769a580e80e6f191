#pragma once
// Reading YAML configuration files so that a user sees every mistake at once: each helper
// appends "<where>: <what is wrong>" to an error list, and throw_if_errors() turns the list into
// one urs::util::ConfigError naming the file.

#include <yaml-cpp/yaml.h>

#include <functional>
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

// The list of non-empty strings at root[key], appended to `out` (nothing if the key is absent);
// false after appending "<key>: must be a list of strings" or "<key>[i]: ..." errors.
bool read_string_list(const YAML::Node& root, const std::string& key, std::vector<std::string>& out,
                      std::vector<std::string>& errors);

bool is_directory(const std::string& path);  // an existing folder (symbolic links followed)
// read_string_list() whose every entry must be an existing folder ("<key>[i]: '<x>' is not a folder").
bool read_folder_list(const YAML::Node& root, const std::string& key, std::vector<std::string>& out,
                      std::vector<std::string>& errors);

// Appends an error for every key of the map `node` not in `allowed`.
void check_keys(const YAML::Node& node, const std::string& where, const std::set<std::string>& allowed,
                std::vector<std::string>& errors);

// Visits each element of the YAML list `list` (at key path `where`) as `visit(entry, "where[i]")`
// after checking its keys against `allowed`; an element that is not a map is reported as
// "where[i]: must be a map with <entry_shape>" and skipped.
void for_each_map(const YAML::Node& list, const std::string& where, const std::string& entry_shape,
                  const std::set<std::string>& allowed, std::vector<std::string>& errors,
                  const std::function<void(const YAML::Node& entry, const std::string& where)>& visit);

// ConfigError "<subject> has N error(s):" with one error per line, if there are any; `subject`
// names what was read, e.g. "--config 'sam.yaml'".
void throw_if_errors(const std::vector<std::string>& errors, const std::string& subject);

}  // namespace urs::util
