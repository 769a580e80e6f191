#include "urs/camus_server/topic_index.hpp"

namespace urs::camus_server {

TopicIndex::TopicIndex() : root_(std::make_unique<Node>()) {}

TopicIndex::~TopicIndex() = default;

void TopicIndex::insert(const TopicPattern& pattern, const Key& key) {
  Node* node = root_.get();
  for (const auto& level : pattern.levels()) {
    std::unique_ptr<Node>* child = nullptr;
    if (level == "*") {
      child = &node->star;
    } else {
      auto it = node->literal.find(level);
      if (it == node->literal.end()) it = node->literal.emplace(level, nullptr).first;
      child = &it->second;
    }
    if (!*child) {
      *child = std::make_unique<Node>();
      ++nodes_;
    }
    node = child->get();
  }
  auto& keys = pattern.tail() ? node->rest : node->exact;
  if (keys.insert(key).second) ++size_;
}

void TopicIndex::erase(const TopicPattern& pattern, const Key& key) {
  // The path from the root, to prune it bottom-up.
  std::vector<std::pair<Node*, const std::string*>> path;
  Node* node = root_.get();
  for (const auto& level : pattern.levels()) {
    Node* next = nullptr;
    if (level == "*") {
      next = node->star.get();
    } else {
      auto it = node->literal.find(level);
      if (it != node->literal.end()) next = it->second.get();
    }
    if (next == nullptr) return;
    path.emplace_back(node, &level);
    node = next;
  }
  auto& keys = pattern.tail() ? node->rest : node->exact;
  if (keys.erase(key) == 0) return;
  --size_;
  while (!path.empty() && node->empty()) {
    auto [parent, level] = path.back();
    path.pop_back();
    if (*level == "*") {
      parent->star.reset();
    } else {
      parent->literal.erase(parent->literal.find(*level));
    }
    --nodes_;
    node = parent;
  }
}

size_t TopicIndex::match(std::string_view topic, std::vector<Key>& out) const {
  const auto levels = topic_levels(topic);
  return collect(*root_, levels, 0, out);
}

size_t TopicIndex::collect(const Node& node, const std::vector<std::string_view>& levels, size_t at,
                           std::vector<Key>& out) {
  // "#" matches the remaining levels, however many (also none).
  out.insert(out.end(), node.rest.begin(), node.rest.end());
  if (at == levels.size()) {
    out.insert(out.end(), node.exact.begin(), node.exact.end());
    return 1;
  }
  size_t visited = 1;
  auto it = node.literal.find(levels[at]);
  if (it != node.literal.end()) visited += collect(*it->second, levels, at + 1, out);
  if (node.star) visited += collect(*node.star, levels, at + 1, out);
  return visited;
}

}  // namespace urs::camus_server
