#include "urs/camus_server/topic_pattern.hpp"

namespace urs::camus_server {

std::vector<std::string_view> topic_levels(std::string_view text) {
  std::vector<std::string_view> levels;
  size_t start = 0;
  for (;;) {
    size_t slash = text.find('/', start);
    if (slash == std::string_view::npos) {
      levels.push_back(text.substr(start));
      return levels;
    }
    levels.push_back(text.substr(start, slash - start));
    start = slash + 1;
  }
}

std::string quote_prefix(std::string_view text, size_t bytes) {
  if (text.size() <= bytes) return "'" + std::string(text) + "'";
  return "'" + std::string(text.substr(0, bytes)) + "...' (" + std::to_string(text.size()) + " bytes)";
}

namespace {

// Why `text` is over `limits`, counted without splitting it; empty if within.
std::string over_limits(std::string_view text, const TopicLimits& limits) {
  if (text.size() > limits.max_bytes) {
    return "it is " + std::to_string(text.size()) + " bytes long; the limit is " + std::to_string(limits.max_bytes) +
           " (max_topic_bytes)";
  }
  size_t levels = 1;
  for (char c : text) levels += c == '/' ? 1 : 0;
  if (levels > limits.max_levels) {
    return "it has " + std::to_string(levels) + " levels; the limit is " + std::to_string(limits.max_levels) +
           " (max_topic_levels)";
  }
  return {};
}

bool has_space(std::string_view level) {
  for (char c : level) {
    if (c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\0') return true;
  }
  return false;
}

}  // namespace

std::string topic_problem(std::string_view topic, const TopicLimits& limits) {
  if (topic.empty()) return "it is empty";
  if (auto why = over_limits(topic, limits); !why.empty()) return why;
  auto levels = topic_levels(topic);
  for (size_t i = 0; i < levels.size(); ++i) {
    auto level = levels[i];
    std::string where = "level " + std::to_string(i + 1);
    if (level.empty()) return where + " is empty";
    if (level.find_first_of("*#") != std::string_view::npos) {
      return where + " ('" + std::string(level) + "') holds a wildcard";
    }
    if (has_space(level)) return where + " ('" + std::string(level) + "') holds white space";
  }
  return {};
}

Result<TopicPattern> TopicPattern::parse(const std::string& text, const TopicLimits& limits) {
  auto invalid = [&text](const std::string& why) {
    return make_error(planet::BAD_ARGUMENTS, "invalid pattern " + quote_prefix(text) + ": " + why);
  };
  if (text.empty()) return invalid("it is empty");
  if (auto why = over_limits(text, limits); !why.empty()) return invalid(why);
  TopicPattern pattern;
  pattern.text_ = text;
  pattern.exact_ = true;
  auto levels = topic_levels(text);
  for (size_t i = 0; i < levels.size(); ++i) {
    auto level = levels[i];
    std::string where = "level " + std::to_string(i + 1);
    if (level.empty()) return invalid(where + " is empty");
    if (has_space(level)) return invalid(where + " ('" + std::string(level) + "') holds white space");
    if (level == "#") {
      if (i + 1 != levels.size()) return invalid("'#' is only allowed as the last level");
      pattern.tail_ = true;
      pattern.exact_ = false;
      continue;
    }
    if (level == "*") {
      pattern.exact_ = false;
    } else if (level.find_first_of("*#") != std::string_view::npos) {
      return invalid(where + " ('" + std::string(level) +
                     "') mixes a wildcard with text; '*' and '#' must be a whole level");
    }
    pattern.levels_.emplace_back(level);
  }
  return pattern;
}

bool TopicPattern::matches(std::string_view topic) const {
  if (text_.empty() || topic.empty()) return false;
  auto levels = topic_levels(topic);
  if (levels.size() < levels_.size()) return false;
  if (!tail_ && levels.size() != levels_.size()) return false;
  for (size_t i = 0; i < levels_.size(); ++i) {
    if (levels_[i] != "*" && levels_[i] != levels[i]) return false;
    if (levels_[i] == "*" && levels[i].empty()) return false;
  }
  return true;
}

bool glob_match(std::string_view pattern, std::string_view text) {
  // Iterative matcher with one backtrack point (the last '*').
  size_t p = 0;
  size_t t = 0;
  size_t star = std::string_view::npos;
  size_t resume = 0;
  while (t < text.size()) {
    if (p < pattern.size() && (pattern[p] == '?' || pattern[p] == text[t])) {
      ++p;
      ++t;
    } else if (p < pattern.size() && pattern[p] == '*') {
      star = p++;
      resume = t;
    } else if (star != std::string_view::npos) {
      p = star + 1;
      t = ++resume;
    } else {
      return false;
    }
  }
  while (p < pattern.size() && pattern[p] == '*') ++p;
  return p == pattern.size();
}

}  // namespace urs::camus_server
