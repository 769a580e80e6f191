#include "urs/bridge/dds/call_authorization.hpp"

#include <algorithm>
#include <cctype>

#include "urs/bridge/core/rules.hpp"  // glob_match

namespace urs::bridge {

std::string caller_pattern_problem(const std::string& pattern) {
  if (pattern.empty()) return "is empty (a space, or SPACE/NAME)";
  if (std::any_of(pattern.begin(), pattern.end(), [](unsigned char c) { return std::isspace(c) || c < 0x20; })) {
    return "'" + pattern + "' contains white space";
  }
  const std::size_t slash = pattern.find('/');
  if (slash == std::string::npos) return "";
  if (pattern.find('/', slash + 1) != std::string::npos) {
    return "'" + pattern + "' has more than one '/' (a space, or SPACE/NAME)";
  }
  if (slash == 0) return "'" + pattern + "' names no space before '/'";
  if (slash + 1 == pattern.size()) return "'" + pattern + "' names no caller after '/'";
  return "";
}

std::string caller_text(const call::Identity& caller) {
  if (caller.name == "dds:" + caller.space) return "space " + caller.space;
  return caller.space + "/" + caller.name;
}

bool caller_matches(const std::string& pattern, const call::Identity& caller) {
  const std::size_t slash = pattern.find('/');
  if (slash == std::string::npos) return glob_match(pattern, caller.space);
  return glob_match(pattern.substr(0, slash), caller.space) && glob_match(pattern.substr(slash + 1), caller.name);
}

std::optional<std::string> refusal(const CallerPolicy& policy, const std::string& space, const call::Request& request) {
  if (!policy.enabled) return std::nullopt;
  const call::Identity& caller = request.caller;
  const std::string target = space + "/" + request.service;
  if (caller.role != federation::kVerifiedSpaceRole && !policy.trust_declared_space) {
    return caller_text(caller) + " may not call " + target + ": its space is only declared, not proven by a " +
           "certificate of the link (dds.export.trust_declared_space is off)";
  }
  for (const CallerRule& rule : policy.rules) {
    if (!glob_match(rule.services, request.service)) continue;
    for (const std::string& pattern : rule.callers) {
      if (caller_matches(pattern, caller)) return std::nullopt;
    }
    return caller_text(caller) + " may not call " + target;
  }
  return caller_text(caller) + " may not call " + target + " (no dds.export.callers rule names the service)";
}

}  // namespace urs::bridge
