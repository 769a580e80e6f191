#pragma once
// Topics and subscription patterns.
//
// A topic is one or more non-empty levels separated by "/" ("kr/robot1/arrived"); levels hold no
// "*", "#" or white space. A pattern has the same shape, where a level may also be
//   "*"  exactly one level, any value;
//   "#"  zero or more trailing levels (only as the last level: "kr/#" matches "kr" and "kr/a/b").
// Anything else matches itself exactly.

#include <string>
#include <string_view>
#include <vector>

#include "urs/camus_server/result.hpp"

namespace urs::camus_server {

class TopicPattern {
 public:
  TopicPattern() = default;  // matches nothing
  // BAD_ARGUMENTS "invalid pattern 'p': <why>" when malformed.
  static Result<TopicPattern> parse(const std::string& text);

  bool matches(std::string_view topic) const;
  const std::string& text() const { return text_; }
  // True if the pattern has no wildcard (it names exactly one topic).
  bool exact() const { return exact_; }

 private:
  std::string text_;
  std::vector<std::string> levels_;
  bool tail_ = false;   // ends with "#" (not stored in levels_)
  bool exact_ = false;
};

// Empty when `topic` is valid, otherwise why not ("level 2 is empty").
std::string topic_problem(std::string_view topic);

// Glob on names: "*" matches any run of characters (also none), "?" exactly one; no escapes.
bool glob_match(std::string_view pattern, std::string_view text);

}  // namespace urs::camus_server
