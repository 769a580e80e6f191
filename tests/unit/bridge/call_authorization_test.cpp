// Who may call which exported service (dds.export.callers): the first rule naming the service
// decides, callers by space or space/name (globs), unproven spaces only where trusted.

#include "urs/bridge/dds/call_authorization.hpp"

#include <gtest/gtest.h>

namespace urs::bridge {
namespace {

call::Request request_from(const std::string& space, const std::string& service, bool verified = true) {
  call::Request request;
  request.service = service;
  request.operation = "ping";
  request.caller = {space, "dds:" + space, verified ? federation::kVerifiedSpaceRole : federation::kDeclaredSpaceRole};
  return request;
}

CallerPolicy policy() {
  CallerPolicy p;
  p.enabled = true;
  p.rules = {{"rt.Secret*", {}}, {"rt.Diagnostic*", {"kr", "us/dds:us"}}, {"*", {"k?", "eu-*"}}};
  return p;
}

TEST(CallAuthorization, WithoutRulesEveryCallerPasses) {
  EXPECT_FALSE(refusal(CallerPolicy{}, "jp", request_from("xx", "rt.Secret0", false)));
}

TEST(CallAuthorization, TheFirstRuleNamingTheServiceDecides) {
  EXPECT_FALSE(refusal(policy(), "jp", request_from("kr", "rt.Diagnostic0")));
  EXPECT_FALSE(refusal(policy(), "jp", request_from("us", "rt.Diagnostic0")));     // by its bridge's name
  EXPECT_FALSE(refusal(policy(), "jp", request_from("ko", "robot1.navigation")));  // '*' rule, glob k?
  EXPECT_FALSE(refusal(policy(), "jp", request_from("eu-west", "robot1.navigation")));
  // rt.Secret0 matches the first rule (nobody) before '*', which would let kr in.
  EXPECT_EQ(refusal(policy(), "jp", request_from("kr", "rt.Secret0")), "space kr may not call jp/rt.Secret0");
  // rt.Diagnostic0 matches its own rule, which does not list ko, before '*', which would.
  EXPECT_EQ(refusal(policy(), "jp", request_from("ko", "rt.Diagnostic0")), "space ko may not call jp/rt.Diagnostic0");
}

TEST(CallAuthorization, AServiceNoRuleNamesIsRefused) {
  CallerPolicy p;
  p.enabled = true;
  p.rules = {{"rt.*", {"*"}}};
  EXPECT_EQ(refusal(p, "jp", request_from("kr", "tts")),
            "space kr may not call jp/tts (no dds.export.callers rule names the service)");
}

TEST(CallAuthorization, ANameInsideTheSpaceMustMatchWhenThePatternHasOne) {
  const call::Identity bridge{"us", "dds:us", federation::kVerifiedSpaceRole};
  EXPECT_TRUE(caller_matches("us", bridge));
  EXPECT_TRUE(caller_matches("us/dds:*", bridge));
  EXPECT_TRUE(caller_matches("*/dds:us", bridge));
  EXPECT_FALSE(caller_matches("us/operator-*", bridge));
  EXPECT_FALSE(caller_matches("kr", bridge));
  EXPECT_FALSE(caller_matches("u", bridge));  // whole names, not prefixes
}

TEST(CallAuthorization, ACallerNamedInsideItsSpaceIsJudgedAndRefusedByItsName) {
  CallerPolicy p;
  p.enabled = true;
  p.rules = {{"rt.Diagnostic*", {"kr/operator-*"}}};
  call::Request request = request_from("kr", "rt.Diagnostic0");
  EXPECT_EQ(refusal(p, "jp", request), "space kr may not call jp/rt.Diagnostic0");  // the bridge itself
  request.caller.name = "operator-ann";
  EXPECT_FALSE(refusal(p, "jp", request));
  request.caller.name = "visitor";
  EXPECT_EQ(refusal(p, "jp", request), "kr/visitor may not call jp/rt.Diagnostic0");
  request.caller.role = federation::kDeclaredSpaceRole;
  EXPECT_EQ(refusal(p, "jp", request),
            "kr/visitor may not call jp/rt.Diagnostic0: its space is only declared, not "
            "proven by a certificate of the link (dds.export.trust_declared_space is off)");
}

TEST(CallAuthorization, CallerNameProblemsAreNamed) {
  for (const char* good : {"operator-ann", "sam-robot1", "anonymous", "a"}) {
    EXPECT_EQ(caller_name_problem(good), "") << good;
  }
  EXPECT_EQ(caller_name_problem(""), "is empty");
  EXPECT_EQ(caller_name_problem(std::string(kMaxCallerName + 1, 'a')), "is 129 bytes long (at most 128)");
  EXPECT_EQ(caller_name_problem("ann smith"), "holds white space or a character outside printable ASCII");
  EXPECT_EQ(caller_name_problem("ann\\n"), "");  // a backslash is printable
  EXPECT_EQ(caller_name_problem(std::string("ann\x00", 4)), "holds white space or a character outside printable ASCII");
  EXPECT_EQ(caller_name_problem("task:square-path/r3"), "");  // a CAMUS task's calls
  EXPECT_TRUE(caller_matches("kr/task:*", {"kr", "task:square-path/r3", federation::kVerifiedSpaceRole}));
  EXPECT_EQ(caller_name_problem("dds:kr"), "'dds:kr' begins with 'dds:' (the bridges' own names)");
}

TEST(CallAuthorization, ADeclaredSpaceIsJudgedOnlyWhereTrusted) {
  CallerPolicy p = policy();
  const auto refused = refusal(p, "jp", request_from("kr", "rt.Diagnostic0", false));
  ASSERT_TRUE(refused);
  EXPECT_EQ(*refused,
            "space kr may not call jp/rt.Diagnostic0: its space is only declared, not proven by a "
            "certificate of the link (dds.export.trust_declared_space is off)");
  p.trust_declared_space = true;
  EXPECT_FALSE(refusal(p, "jp", request_from("kr", "rt.Diagnostic0", false)));
  EXPECT_EQ(refusal(p, "jp", request_from("kr", "rt.Secret0", false)), "space kr may not call jp/rt.Secret0");
}

TEST(CallAuthorization, PatternProblemsAreNamed) {
  for (const char* good : {"kr", "kr/operator-*", "*"}) EXPECT_EQ(caller_pattern_problem(good), "") << good;
  for (const char* bad : {"", "a/b/c", "/a", "a/", "a b"})
    EXPECT_NE(caller_pattern_problem(bad), "") << "'" << bad << "'";
}

}  // namespace
}  // namespace urs::bridge
