#pragma once
// An index of subscription patterns over topic levels, so that finding the subscriptions of an
// event costs what the event's topic can reach, not one test per subscription.
//
// A trie of pattern levels: each node has one child per literal level, one "*" child, the
// patterns that end there and the patterns that end there with "#". Matching a topic of L levels
// walks, level by level, the literal child of that level (one map lookup) and the "*" child, and
// collects the "#" patterns of every node it passes. A subscription whose pattern differs from
// the topic at a literal level is never visited, so 2,000 such subscriptions cost an event
// nothing; the work per event is bounded by L times the number of "*" branches its prefix
// reaches. Each pattern costs at most one node per level (at most TopicLimits::max_levels).
//
// Not thread-safe: the event bus owns one and uses it on its own thread only.

#include <cstddef>
#include <cstdint>
#include <map>
#include <memory>
#include <set>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "urs/camus_server/topic_pattern.hpp"

namespace urs::camus_server {

class TopicIndex {
 public:
  using Key = std::pair<uint64_t, uint64_t>;  // (owner, subscription id)

  TopicIndex();
  ~TopicIndex();
  TopicIndex(const TopicIndex&) = delete;
  TopicIndex& operator=(const TopicIndex&) = delete;

  // Adds `key` under `pattern`. A key is added once (the caller keeps keys unique).
  void insert(const TopicPattern& pattern, const Key& key);
  // Removes `key` from under `pattern` and prunes the nodes left empty. Unknown keys are ignored.
  void erase(const TopicPattern& pattern, const Key& key);
  // Appends to `out` the key of every pattern that matches the valid topic `topic`, each once.
  // Returns how many trie nodes were visited (the work done).
  size_t match(std::string_view topic, std::vector<Key>& out) const;

  size_t size() const { return size_; }
  size_t nodes() const { return nodes_; }  // trie nodes, the root included

 private:
  struct Node {
    std::map<std::string, std::unique_ptr<Node>, std::less<>> literal;
    std::unique_ptr<Node> star;
    std::set<Key> exact;  // patterns that end at this node
    std::set<Key> rest;   // patterns that end at this node with "#"
    bool empty() const { return literal.empty() && !star && exact.empty() && rest.empty(); }
  };
  static size_t collect(const Node& node, const std::vector<std::string_view>& levels, size_t at,
                        std::vector<Key>& out);

  std::unique_ptr<Node> root_;
  size_t size_ = 0;
  size_t nodes_ = 1;
};

}  // namespace urs::camus_server
