#include "urs/camus_server/topic_pattern.hpp"

#include <gtest/gtest.h>

namespace urs::camus_server {
namespace {

struct MatchCase {
  const char* pattern;
  const char* topic;
  bool matches;
};

class PatternMatch : public ::testing::TestWithParam<MatchCase> {};

TEST_P(PatternMatch, MatchesAsSpecified) {
  const auto& c = GetParam();
  auto pattern = TopicPattern::parse(c.pattern);
  ASSERT_TRUE(pattern.ok()) << pattern.message();
  EXPECT_EQ(pattern->matches(c.topic), c.matches) << c.pattern << " vs " << c.topic;
}

INSTANTIATE_TEST_SUITE_P(
    Table, PatternMatch,
    ::testing::Values(MatchCase{"a/b/c", "a/b/c", true}, MatchCase{"a/b/c", "a/b", false},
                      MatchCase{"a/b/c", "a/b/c/d", false}, MatchCase{"a/b", "a/bb", false},
                      MatchCase{"a/*/c", "a/x/c", true}, MatchCase{"a/*/c", "a/c", false},
                      MatchCase{"a/*/c", "a/x/y/c", false}, MatchCase{"*", "a", true}, MatchCase{"*", "a/b", false},
                      MatchCase{"*/*", "a/b", true}, MatchCase{"a/#", "a", true},  // '#' matches zero levels
                      MatchCase{"a/#", "a/b", true}, MatchCase{"a/#", "a/b/c/d", true}, MatchCase{"a/#", "b/a", false},
                      MatchCase{"a/#", "ab", false}, MatchCase{"#", "a", true}, MatchCase{"#", "x/y/z", true},
                      MatchCase{"*/arrived", "robot1.navigation/arrived", true}, MatchCase{"*/#", "a", true},
                      MatchCase{"*/b/#", "a/b", true}, MatchCase{"*/b/#", "a/c", false},
                      MatchCase{"context/robot1/#", "context/robot1/pose", true},
                      MatchCase{"task/square-path/*", "task/square-path/r1", true}));

struct InvalidCase {
  const char* pattern;
  const char* message;
};

class PatternInvalid : public ::testing::TestWithParam<InvalidCase> {};

TEST_P(PatternInvalid, IsRefusedWithReason) {
  const auto& c = GetParam();
  auto pattern = TopicPattern::parse(c.pattern);
  ASSERT_FALSE(pattern.ok());
  EXPECT_EQ(pattern.status(), planet::BAD_ARGUMENTS);
  EXPECT_EQ(pattern.message(), c.message);
}

INSTANTIATE_TEST_SUITE_P(
    Table, PatternInvalid,
    ::testing::Values(InvalidCase{"", "invalid pattern '': it is empty"},
                      InvalidCase{"a/#/b", "invalid pattern 'a/#/b': '#' is only allowed as the last level"},
                      InvalidCase{"a//b", "invalid pattern 'a//b': level 2 is empty"},
                      InvalidCase{"/a", "invalid pattern '/a': level 1 is empty"},
                      InvalidCase{"a/", "invalid pattern 'a/': level 2 is empty"},
                      InvalidCase{"a/b*",
                                  "invalid pattern 'a/b*': level 2 ('b*') mixes a wildcard with text; '*' and "
                                  "'#' must be a whole level"},
                      InvalidCase{"a b", "invalid pattern 'a b': level 1 ('a b') holds white space"}));

TEST(Topic, ProblemsAreNamed) {
  EXPECT_EQ(topic_problem("kr/robot1/arrived"), "");
  EXPECT_EQ(topic_problem(""), "it is empty");
  EXPECT_EQ(topic_problem("a//b"), "level 2 is empty");
  EXPECT_EQ(topic_problem("a/*"), "level 2 ('*') holds a wildcard");
  EXPECT_EQ(topic_problem("a/#"), "level 2 ('#') holds a wildcard");
}

TEST(Pattern, ExactnessIsReported) {
  EXPECT_TRUE(TopicPattern::parse("a/b").value().exact());
  EXPECT_FALSE(TopicPattern::parse("a/*").value().exact());
  EXPECT_FALSE(TopicPattern::parse("a/#").value().exact());
}

TEST(Glob, MatchesNames) {
  EXPECT_TRUE(glob_match("*", ""));
  EXPECT_TRUE(glob_match("*", "robot1.navigation"));
  EXPECT_TRUE(glob_match("robot1.*", "robot1.navigation"));
  EXPECT_FALSE(glob_match("robot1.*", "robot2.navigation"));
  EXPECT_TRUE(glob_match("*.navigation", "robot1.navigation"));
  EXPECT_TRUE(glob_match("camus.*", "camus.context"));
  EXPECT_TRUE(glob_match("r?bot1*", "robot1.tts"));
  EXPECT_TRUE(glob_match("*a*b*", "xxaxxbxx"));
  EXPECT_FALSE(glob_match("*a*b", "xxaxxbxx"));
  EXPECT_TRUE(glob_match("exact", "exact"));
  EXPECT_FALSE(glob_match("exact", "exactly"));
}

}  // namespace
}  // namespace urs::camus_server
