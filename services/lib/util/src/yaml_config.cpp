#include "urs/util/yaml_config.hpp"

#include <sys/stat.h>

#include <sstream>

#include "urs/util/cli.hpp"

namespace urs::util {

YAML::Node load_yaml_file(const std::string& path, const std::string& flag) {
  try {
    return YAML::LoadFile(path);
  } catch (const YAML::BadFile&) {
    throw ConfigError(flag + ": cannot read '" + path + "'");
  } catch (const YAML::Exception& e) {
    throw ConfigError(flag + ": '" + path + "' is not valid YAML: " + e.what());
  }
}

std::string join(const std::set<std::string>& items) {
  std::string out;
  for (const auto& item : items) out += (out.empty() ? "" : ", ") + item;
  return out;
}

void check_keys(const YAML::Node& node, const std::string& where, const std::set<std::string>& allowed,
                std::vector<std::string>& errors) {
  for (const auto& kv : node) {
    auto key = kv.first.as<std::string>();
    if (allowed.count(key) == 0) {
      errors.push_back(where + (where.empty() ? "" : ".") + key + ": unknown key (allowed: " + join(allowed) + ")");
    }
  }
}

bool read_string_list(const YAML::Node& root, const std::string& key, std::vector<std::string>& out,
                      std::vector<std::string>& errors) {
  const YAML::Node list = root[key];
  if (!list) return true;
  if (!list.IsSequence()) {
    errors.push_back(key + ": must be a list of strings");
    return false;
  }
  bool ok = true;
  for (std::size_t i = 0; i < list.size(); ++i) {
    std::string value;
    const std::string where = key + "[" + std::to_string(i) + "]";
    if (!list[i].IsScalar() || !read_scalar(list[i], where, value, errors)) {
      if (!list[i].IsScalar()) errors.push_back(where + ": must be a string");
      ok = false;
    } else if (value.empty()) {
      errors.push_back(where + ": must not be empty");
      ok = false;
    } else {
      out.push_back(value);
    }
  }
  return ok;
}

bool is_directory(const std::string& path) {
  struct stat info {};
  return ::stat(path.c_str(), &info) == 0 && S_ISDIR(info.st_mode);
}

bool read_folder_list(const YAML::Node& root, const std::string& key, std::vector<std::string>& out,
                      std::vector<std::string>& errors) {
  if (!read_string_list(root, key, out, errors)) return false;
  bool ok = true;
  for (std::size_t i = 0; i < out.size(); ++i) {
    if (!is_directory(out[i])) {
      errors.push_back(key + "[" + std::to_string(i) + "]: '" + out[i] + "' is not a folder");
      ok = false;
    }
  }
  return ok;
}

void for_each_map(const YAML::Node& list, const std::string& where, const std::string& entry_shape,
                  const std::set<std::string>& allowed, std::vector<std::string>& errors,
                  const std::function<void(const YAML::Node& entry, const std::string& where)>& visit) {
  for (std::size_t i = 0; i < list.size(); ++i) {
    const std::string at = where + "[" + std::to_string(i) + "]";
    const YAML::Node entry = list[i];
    if (!entry.IsMap()) {
      errors.push_back(at + ": must be a map with " + entry_shape);
      continue;
    }
    check_keys(entry, at, allowed, errors);
    visit(entry, at);
  }
}

void throw_if_errors(const std::vector<std::string>& errors, const std::string& subject) {
  if (errors.empty()) return;
  std::ostringstream out;
  out << subject << " has " << errors.size() << " error(s):";
  for (const auto& e : errors) out << "\n  " << e;
  throw ConfigError(out.str());
}

}  // namespace urs::util
