#pragma once
// Topics and subscription patterns.
//
// A topic is one or more non-empty levels separated by "/" ("kr/robot1/arrived"); levels hold no
// "*", "#" or white space. A pattern has the same shape, where a level may also be
//   "*"  exactly one level, any value;
//   "#"  zero or more trailing levels (only as the last level: "kr/#" matches "kr" and "kr/a/b").
// Anything else matches itself exactly.
//
// Both are bounded (TopicLimits): the length and the number of levels are checked before the text
// is split, so a 60 KB pattern or a 30,000-level topic costs nothing but its refusal.

#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

#include "urs/camus_server/result.hpp"

namespace urs::camus_server {

// Largest topic or pattern accepted; the server's flags --max-topic-bytes / --max-topic-levels.
struct TopicLimits {
  size_t max_bytes = 512;
  size_t max_levels = 32;
};

class TopicPattern {
 public:
  TopicPattern() = default;  // matches nothing
  // BAD_ARGUMENTS "invalid pattern 'p': <why>" when malformed or over `limits` (the message then
  // quotes only the pattern's first 64 bytes and names the limit).
  static Result<TopicPattern> parse(const std::string& text, const TopicLimits& limits = {});

  bool matches(std::string_view topic) const;
  const std::string& text() const { return text_; }
  // True if the pattern has no wildcard (it names exactly one topic).
  bool exact() const { return exact_; }
  // The levels before a trailing "#" ("*" included as such), and whether that "#" is there.
  const std::vector<std::string>& levels() const { return levels_; }
  bool tail() const { return tail_; }

 private:
  std::string text_;
  std::vector<std::string> levels_;
  bool tail_ = false;  // ends with "#" (not stored in levels_)
  bool exact_ = false;
};

// Empty when `topic` is valid within `limits`, otherwise why not ("level 2 is empty", "it has 40
// levels; the limit is 32 (max_topic_levels)").
std::string topic_problem(std::string_view topic, const TopicLimits& limits = {});

// The levels of a valid topic, as views into it.
std::vector<std::string_view> topic_levels(std::string_view topic);

// `text` for an error message: itself if short, else its first `bytes` bytes and the total size.
std::string quote_prefix(std::string_view text, size_t bytes = 64);

// Glob on names: "*" matches any run of characters (also none), "?" exactly one; no escapes.
bool glob_match(std::string_view pattern, std::string_view text);

}  // namespace urs::camus_server
