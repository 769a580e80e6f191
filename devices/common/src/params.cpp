#include "urs/devices/params.hpp"

#include <cmath>

#include "urs/util/number.hpp"
#include "urs/util/yaml_config.hpp"

namespace urs::devices {
namespace {

std::string describe(const std::string& device, const std::vector<ParamProblem>& problems) {
  std::string text = device + " params: " + std::to_string(problems.size()) + " error(s):";
  for (const auto& p : problems) text += "\n  " + (p.key.empty() ? "params" : p.key) + ": " + p.what;
  return text;
}

}  // namespace

ParamError::ParamError(std::string device, std::vector<ParamProblem> problems)
    : util::ConfigError(describe(device, problems)), device_(std::move(device)), problems_(std::move(problems)) {}

struct ParamReader::Problems {
  std::string device;
  std::vector<ParamProblem> list;
};

ParamReader::ParamReader(std::string device, const YAML::Node& params, const std::set<std::string>& allowed)
    : problems_(std::make_shared<Problems>()), node_(params) {
  problems_->device = std::move(device);
  if (!node_ || node_.IsNull()) {
    node_ = YAML::Node(YAML::NodeType::Map);
  } else if (!node_.IsMap()) {
    fail("", "must be a map (keys: " + util::join(allowed) + ")");
    node_ = YAML::Node(YAML::NodeType::Map);
  } else {
    check_keys(allowed);
  }
}

ParamReader::ParamReader(std::shared_ptr<Problems> problems, YAML::Node node, std::string path)
    : problems_(std::move(problems)), node_(std::move(node)), path_(std::move(path)) {}

std::string ParamReader::path_of(const std::string& key) const {
  if (path_.empty()) return key;
  return key.empty() ? path_ : path_ + "." + key;
}

void ParamReader::check_keys(const std::set<std::string>& allowed) {
  for (const auto& kv : node_) {
    const std::string key = kv.first.IsScalar() ? kv.first.Scalar() : YAML::Dump(kv.first);
    if (allowed.count(key) == 0) fail(key, "unknown key (allowed: " + util::join(allowed) + ")");
  }
}

bool ParamReader::has(const std::string& key) const { return static_cast<bool>(node_[key]); }

void ParamReader::fail(const std::string& key, const std::string& what) {
  problems_->list.push_back({path_of(key), what});
}

bool ParamReader::failed() const { return !problems_->list.empty(); }

void ParamReader::finish() const {
  if (!problems_->list.empty()) throw ParamError(problems_->device, problems_->list);
}

std::optional<std::string> ParamReader::scalar(const std::string& key, const char* kind) {
  const YAML::Node node = node_[key];
  if (!node) return std::nullopt;
  if (!node.IsScalar()) {
    fail(key, std::string("must be ") + kind);
    return std::nullopt;
  }
  return node.Scalar();
}

double ParamReader::number(const std::string& key, double fallback, double min, double max) {
  const auto text = scalar(key, "a number");
  if (!text) return fallback;
  double value = fallback;
  const std::string why = util::read_number(*text, min, max, value);
  if (!why.empty()) {
    fail(key, why);
    return fallback;
  }
  return value;
}

std::optional<double> ParamReader::whole_number(const std::string& key, double min, double max) {
  const auto text = scalar(key, "a whole number");
  if (!text) return std::nullopt;
  double value = 0;
  const std::string why = util::read_number(*text, min, max, value);
  if (!why.empty()) {
    fail(key, why);
    return std::nullopt;
  }
  if (value != std::floor(value)) {
    fail(key, "'" + *text + "' is not a whole number");
    return std::nullopt;
  }
  return value;
}

std::string ParamReader::text(const std::string& key, const std::string& fallback) {
  const auto value = scalar(key, "a string");
  if (!value) return fallback;
  if (value->empty()) {
    fail(key, "must not be empty");
    return fallback;
  }
  return *value;
}

std::string ParamReader::choice(const std::string& key, const std::string& fallback,
                                const std::set<std::string>& allowed) {
  const std::string value = text(key, fallback);
  if (allowed.count(value) == 0) {
    fail(key, "'" + value + "' is not one of " + util::join(allowed));
    return fallback;
  }
  return value;
}

std::vector<std::string> ParamReader::text_list(const std::string& key, const std::vector<std::string>& fallback) {
  const YAML::Node node = node_[key];
  if (!node) return fallback;
  if (!node.IsSequence()) {
    fail(key, "must be a list of strings");
    return fallback;
  }
  if (node.size() == 0) {
    fail(key, "must not be an empty list");
    return fallback;
  }
  std::vector<std::string> items;
  bool ok = true;
  for (std::size_t i = 0; i < node.size(); ++i) {
    const std::string at = key + "[" + std::to_string(i) + "]";
    if (!node[i].IsScalar()) {
      fail(at, "must be a string");
      ok = false;
    } else if (node[i].Scalar().empty()) {
      fail(at, "must not be empty");
      ok = false;
    } else {
      items.push_back(node[i].Scalar());
    }
  }
  return ok ? items : fallback;
}

uint32_t ParamReader::domain(const std::string& key, uint32_t fallback) {
  return integer<uint32_t>(key, fallback, 0, 232);
}

std::optional<ParamReader> ParamReader::section(const std::string& key, const std::set<std::string>& allowed) {
  const YAML::Node node = node_[key];
  if (!node) return std::nullopt;
  if (!node.IsMap()) {
    fail(key, "must be a map (keys: " + util::join(allowed) + ")");
    return std::nullopt;
  }
  ParamReader inner(problems_, node, path_of(key));
  inner.check_keys(allowed);
  return inner;
}

std::vector<ParamReader> ParamReader::sections(const std::string& key, const std::set<std::string>& allowed) {
  std::vector<ParamReader> out;
  const YAML::Node node = node_[key];
  if (!node) return out;
  if (!node.IsSequence()) {
    fail(key, "must be a list of maps (keys: " + util::join(allowed) + ")");
    return out;
  }
  for (std::size_t i = 0; i < node.size(); ++i) {
    const std::string at = key + "[" + std::to_string(i) + "]";
    if (!node[i].IsMap()) {
      fail(at, "must be a map (keys: " + util::join(allowed) + ")");
      continue;
    }
    ParamReader inner(problems_, node[i], path_of(at));
    inner.check_keys(allowed);
    out.push_back(std::move(inner));
  }
  return out;
}

}  // namespace urs::devices
