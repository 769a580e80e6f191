#pragma once
// Word error counting for recognisers: the minimum-cost alignment (Levenshtein over words, each
// substitution, deletion and insertion costing 1) of a hypothesis against a reference.

#include <cstddef>
#include <string>
#include <vector>

namespace urs::devices {

struct WordErrors {
  std::size_t substitutions = 0;
  std::size_t deletions = 0;   // reference words missing from the hypothesis
  std::size_t insertions = 0;  // hypothesis words not in the reference
  std::size_t reference_words = 0;

  std::size_t errors() const { return substitutions + deletions + insertions; }
  // (S + D + I) / N; 0 when the reference is empty.
  double rate() const;
  WordErrors& operator+=(const WordErrors& other);
};

// Words are split on white space and compared case-insensitively.
WordErrors align_words(const std::string& reference, const std::string& hypothesis);

}  // namespace urs::devices
