#include "urs/bridge/core/rules.hpp"

#include <fnmatch.h>

namespace urs::bridge {

std::string expand(const std::string& pattern, const std::vector<std::pair<std::string, std::string>>& values) {
  std::string out = pattern;
  for (const auto& [name, value] : values) {
    const std::string token = "{" + name + "}";
    for (std::size_t at = out.find(token); at != std::string::npos; at = out.find(token, at + value.size())) {
      out.replace(at, token.size(), value);
    }
  }
  return out;
}

bool glob_match(const std::string& pattern, const std::string& text) {
  return fnmatch(pattern.c_str(), text.c_str(), 0) == 0;
}

bool allowed(const std::string& name, const std::vector<std::string>& allow, const std::vector<std::string>& deny) {
  auto any = [&name](const std::vector<std::string>& patterns) {
    for (const auto& pattern : patterns) {
      if (glob_match(pattern, name)) return true;
    }
    return false;
  };
  return any(allow) && !any(deny);
}

}  // namespace urs::bridge

namespace urs::bridge::core {

bool bridgeable(const Offer& offer) { return offer.origin.empty() && !offer.built_in; }

const RouteRule* first_match(const std::vector<RouteRule>& rules, const Offer& offer) {
  for (const auto& rule : rules) {
    if (allowed(offer.name, rule.allow, rule.deny) && glob_match(rule.interface, offer.interface_name)) return &rule;
  }
  return nullptr;
}

bool NameFilter::admits(const std::string& name) const { return allowed(name, allow, deny); }

std::string stand_in_name(const RouteRule& rule, const Offer& offer) {
  std::vector<std::pair<std::string, std::string>> values = offer.fields;
  values.emplace_back("name", offer.name);
  return expand(rule.name, values);
}

}  // namespace urs::bridge::core
