#pragma once
// Which offers a route carries and under which name: the matching of the bridge's configured
// rules (docs/bridge.md), free of any middleware.

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "urs/bridge/core/offer.hpp"

namespace urs::bridge {

// True if `text` matches the glob `pattern` ('*' and '?' also match '/').
bool glob_match(const std::string& pattern, const std::string& text);
// True if `name` matches one of `allow` and none of `deny`.
bool allowed(const std::string& name, const std::vector<std::string>& allow, const std::vector<std::string>& deny);
// "{instance}.{port}" with {name} replaced by the value given for it; unknown names stay.
std::string expand(const std::string& pattern, const std::vector<std::pair<std::string, std::string>>& values);

}  // namespace urs::bridge

namespace urs::bridge::core {

// One configured rule of a direction: the offers it admits and the name their stand-in gets.
struct RouteRule {
  std::vector<std::string> allow{"*"};  // globs on Offer::name
  std::vector<std::string> deny;
  std::string interface = "*";   // glob on Offer::interface_name
  std::string name = "{name}";   // the stand-in's name: {name} is Offer::name, then Offer::fields
  uint32_t deadline_ms = 10000;  // bound on each call through the route
};

// Globs on the names stand-ins get (a direction's filter after the rules named them).
struct NameFilter {
  std::vector<std::string> allow{"*"};
  std::vector<std::string> deny;
  bool admits(const std::string& name) const;
};

// The first of `rules` that admits `offer` (bridgeable or not: see bridgeable()); nullptr if none.
const RouteRule* first_match(const std::vector<RouteRule>& rules, const Offer& offer);

// The name of the stand-in for `offer` under `rule`.
std::string stand_in_name(const RouteRule& rule, const Offer& offer);

}  // namespace urs::bridge::core
