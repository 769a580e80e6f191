#include "urs/camus_server/topic_index.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>

namespace urs::camus_server {
namespace {

TopicPattern pattern(const std::string& text) {
  auto parsed = TopicPattern::parse(text);
  EXPECT_TRUE(parsed.ok()) << parsed.message();
  return parsed.value();
}

std::vector<TopicIndex::Key> match(const TopicIndex& index, const std::string& topic) {
  std::vector<TopicIndex::Key> out;
  index.match(topic, out);
  std::sort(out.begin(), out.end());
  return out;
}

TEST(TopicIndex, FindsWhatEachPatternMatches) {
  TopicIndex index;
  const std::vector<std::string> patterns = {"a/b/c", "a/*/c", "a/#", "#", "*", "*/b/#", "a/b", "x/y"};
  for (size_t i = 0; i < patterns.size(); ++i) index.insert(pattern(patterns[i]), {1, i});
  using V = std::vector<TopicIndex::Key>;
  EXPECT_EQ(match(index, "a/b/c"), (V{{1, 0}, {1, 1}, {1, 2}, {1, 3}, {1, 5}}));
  EXPECT_EQ(match(index, "a"), (V{{1, 2}, {1, 3}, {1, 4}}));  // "a/#" matches "a"
  EXPECT_EQ(match(index, "a/b"), (V{{1, 2}, {1, 3}, {1, 5}, {1, 6}}));
  EXPECT_EQ(match(index, "q/r"), (V{{1, 3}}));
  EXPECT_EQ(match(index, "x/y"), (V{{1, 3}, {1, 7}}));
}

// The index agrees with TopicPattern::matches on every pair of a random population.
TEST(TopicIndex, AgreesWithThePatternMatcher) {
  std::mt19937 rng(7);
  const std::vector<std::string> words = {"a", "b", "c", "*"};
  auto random_pattern = [&] {
    std::string text;
    const int levels = 1 + static_cast<int>(rng() % 4);
    for (int i = 0; i < levels; ++i) text += (i ? "/" : "") + words[rng() % words.size()];
    if (rng() % 3 == 0) text += "/#";
    return text;
  };
  auto random_topic = [&] {
    std::string text;
    const int levels = 1 + static_cast<int>(rng() % 5);
    for (int i = 0; i < levels; ++i) text += (i ? "/" : "") + words[rng() % 3];
    return text;
  };
  TopicIndex index;
  std::vector<TopicPattern> patterns;
  for (uint64_t i = 0; i < 300; ++i) {
    patterns.push_back(pattern(random_pattern()));
    index.insert(patterns.back(), {i % 7, i});
  }
  for (int t = 0; t < 500; ++t) {
    const std::string topic = random_topic();
    std::vector<TopicIndex::Key> expected;
    for (uint64_t i = 0; i < patterns.size(); ++i) {
      if (patterns[i].matches(topic)) expected.push_back({i % 7, i});
    }
    std::sort(expected.begin(), expected.end());
    EXPECT_EQ(match(index, topic), expected) << topic;
  }
}

TEST(TopicIndex, ErasePrunesEmptyNodes) {
  TopicIndex index;
  index.insert(pattern("a/b/c/d"), {1, 1});
  index.insert(pattern("a/b/*"), {1, 2});
  index.insert(pattern("a/#"), {2, 1});
  EXPECT_EQ(index.size(), 3u);
  EXPECT_EQ(index.nodes(), 6u);  // root, a, b, c, d, *
  index.erase(pattern("a/b/c/d"), {1, 1});
  EXPECT_EQ(index.nodes(), 4u);
  index.erase(pattern("a/b/c/d"), {1, 1});  // unknown: ignored
  index.erase(pattern("a/b/*"), {9, 9});    // unknown key: ignored
  EXPECT_EQ(index.size(), 2u);
  index.erase(pattern("a/b/*"), {1, 2});
  index.erase(pattern("a/#"), {2, 1});
  EXPECT_EQ(index.size(), 0u);
  EXPECT_EQ(index.nodes(), 1u);
  EXPECT_TRUE(match(index, "a/b/c").empty());
}

// The work for an event does not grow with subscriptions that differ from its topic at a literal
// level: 2,000 of them on a 32-level topic's neighbours change nothing.
TEST(TopicIndex, NonMatchingSubscriptionsCostAnEventNothing) {
  std::string topic = "l0";
  for (int i = 1; i < 32; ++i) topic += "/l" + std::to_string(i);
  TopicIndex index;
  index.insert(pattern("l0/#"), {1, 1});
  std::vector<TopicIndex::Key> out;
  const size_t alone = index.match(topic, out);
  for (uint64_t i = 0; i < 2000; ++i) {
    // Same length, differing at the first level, the middle one or the last one.
    std::string other = topic;
    const size_t at = i % 3 == 0 ? 0 : (i % 3 == 1 ? other.find("/l16") + 1 : other.rfind('/') + 1);
    other.insert(at, "x" + std::to_string(i));
    index.insert(pattern(other), {2, i});
  }
  out.clear();
  const size_t among = index.match(topic, out);
  EXPECT_EQ(out, (std::vector<TopicIndex::Key>{{1, 1}}));
  // The subscriptions diverging in the middle or at the end share the topic's prefix, so the walk
  // follows that prefix once: at most one node per level, whatever their number.
  EXPECT_LE(among, alone + 32);
}

}  // namespace
}  // namespace urs::camus_server
