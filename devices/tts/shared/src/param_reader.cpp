#include "urs/devices/param_reader.hpp"

#include "urs/util/cli.hpp"
#include "urs/util/yaml_config.hpp"

namespace urs::devices {

ParamReader::ParamReader(std::string device, const YAML::Node& params, const std::set<std::string>& allowed)
    : device_(std::move(device)), params_(params) {
  if (!params_ || params_.IsNull()) {
    params_ = YAML::Node(YAML::NodeType::Map);
  } else if (!params_.IsMap()) {
    errors_.push_back("params: must be a map (allowed keys: " + util::join(allowed) + ")");
    params_ = YAML::Node(YAML::NodeType::Map);
  }
  util::check_keys(params_, "", allowed, errors_);
}

void ParamReader::text(const std::string& key, std::string& out) {
  if (params_[key]) util::read_scalar(params_[key], key, out, errors_);
}

void ParamReader::nonempty_text(const std::string& key, std::string& out) {
  std::string value = out;
  text(key, value);
  if (value.empty()) {
    fail(key, "must not be empty");
  } else {
    out = value;
  }
}

void ParamReader::read_integer(const std::string& key, long min, long max, long& out) {
  long value = 0;
  if (!params_[key] || !util::read_scalar(params_[key], key, value, errors_)) return;
  if (value < min || value > max) {
    fail(key, std::to_string(value) + " is outside " + std::to_string(min) + ".." + std::to_string(max));
  } else {
    out = value;
  }
}

void ParamReader::number(const std::string& key, double min, double max, double& out) {
  double value = 0;
  if (!params_[key] || !util::read_scalar(params_[key], key, value, errors_)) return;
  if (!(value >= min && value <= max)) {
    fail(key, std::to_string(value) + " is outside " + std::to_string(min) + ".." + std::to_string(max));
  } else {
    out = value;
  }
}

void ParamReader::text_list(const std::string& key, std::vector<std::string>& out) {
  const YAML::Node node = params_[key];
  if (!node) return;
  if (!node.IsSequence()) {
    fail(key, "must be a list of strings");
    return;
  }
  std::vector<std::string> items;
  for (std::size_t i = 0; i < node.size(); ++i) {
    std::string item;
    if (!util::read_scalar(node[i], key + "[" + std::to_string(i) + "]", item, errors_)) return;
    items.push_back(item);
  }
  out = std::move(items);
}

void ParamReader::fail(const std::string& key, const std::string& what) { errors_.push_back(key + ": " + what); }

void ParamReader::finish() const {
  if (errors_.empty()) return;
  std::string text = device_ + " params: ";
  for (std::size_t i = 0; i < errors_.size(); ++i) text += (i == 0 ? "" : "; ") + errors_[i];
  throw util::ConfigError(text);
}

}  // namespace urs::devices
