#pragma once
// Who may call the services this space exports over DDS (`dds.export.callers`, docs/federation.md
// "Who may call what"), decided for each call served from its caller as the link established it
// (call::Request.caller: the space its DDS-Security certificate proves, or the space its request
// merely declares on a plain link, and the name inside that space its request carries, which that
// space's bridge vouches for; docs/security.md "Calls between spaces").
//
// Pure functions over immutable values: any thread; nothing blocks, nothing throws.

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include "urs/call/call.hpp"
#include "urs/federation/dds_link.hpp"  // kVerifiedSpaceRole, kDeclaredSpaceRole

namespace urs::bridge {

// "rt.Diagnostic*": [kr, "jp/operator-*"]: the services matching `services` (a glob on this
// space's service names) may be called by the callers matching one of `callers`, each "SPACE"
// (any caller of that space) or "SPACE/NAME" (the caller of that space named NAME), both globs.
struct CallerRule {
  std::string services;
  std::vector<std::string> callers;
};

struct CallerPolicy {
  // False (no dds.export.callers): every space that reaches the service may call it, as the link's
  // membership and DDS permissions allow. True: only as `rules` say.
  bool enabled = false;
  std::vector<CallerRule> rules;  // the first whose `services` matches the service decides
  // dds.export.trust_declared_space: a caller whose space is only declared (a plain link) is
  // judged by that space; otherwise refused whenever the rules apply.
  bool trust_declared_space = false;
};

// What is wrong with a caller pattern ("kr", "kr/operator-*", "*"), one sentence; "" if nothing.
std::string caller_pattern_problem(const std::string& pattern);

// The check of the name a request gives its caller inside its space (the link makes it).
using federation::caller_name_problem;
using federation::kMaxCallerName;

// The caller as refusals name it: "space kr" for a space's bridge ("dds:kr"), else "kr/operator-ann".
std::string caller_text(const call::Identity& caller);

// True if `caller` matches the caller pattern `pattern` (caller_pattern_problem() empty).
bool caller_matches(const std::string& pattern, const call::Identity& caller);

// Why `request` (a call from another space to the service `request.service` of `space`) is
// refused, for its PERMISSION_DENIED ("space kr may not call jp/rt.Secret0", "kr/visitor may not
// call jp/rt.Diagnostic0"); nullopt if allowed.
std::optional<std::string> refusal(const CallerPolicy& policy, const std::string& space, const call::Request& request);

}  // namespace urs::bridge
