#include "urs/devices/word_errors.hpp"

#include <algorithm>
#include <cctype>
#include <sstream>

namespace urs::devices {

namespace {

std::vector<std::string> words(const std::string& text) {
  std::istringstream in(text);
  std::vector<std::string> out;
  for (std::string w; in >> w;) {
    std::transform(w.begin(), w.end(), w.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    out.push_back(w);
  }
  return out;
}

}  // namespace

double WordErrors::rate() const {
  return reference_words == 0 ? 0.0 : static_cast<double>(errors()) / static_cast<double>(reference_words);
}

WordErrors& WordErrors::operator+=(const WordErrors& other) {
  substitutions += other.substitutions;
  deletions += other.deletions;
  insertions += other.insertions;
  reference_words += other.reference_words;
  return *this;
}

WordErrors align_words(const std::string& reference, const std::string& hypothesis) {
  const auto ref = words(reference);
  const auto hyp = words(hypothesis);
  const std::size_t rows = ref.size() + 1;
  const std::size_t cols = hyp.size() + 1;
  // cost[i][j]: errors aligning the first i reference words with the first j hypothesis words.
  std::vector<std::size_t> cost(rows * cols);
  auto at = [cols](std::size_t i, std::size_t j) { return i * cols + j; };
  for (std::size_t i = 0; i < rows; ++i) cost[at(i, 0)] = i;
  for (std::size_t j = 0; j < cols; ++j) cost[at(0, j)] = j;
  for (std::size_t i = 1; i < rows; ++i) {
    for (std::size_t j = 1; j < cols; ++j) {
      const std::size_t diagonal = cost[at(i - 1, j - 1)] + (ref[i - 1] == hyp[j - 1] ? 0 : 1);
      cost[at(i, j)] = std::min({diagonal, cost[at(i - 1, j)] + 1, cost[at(i, j - 1)] + 1});
    }
  }
  WordErrors errors;
  errors.reference_words = ref.size();
  std::size_t i = ref.size();
  std::size_t j = hyp.size();
  while (i > 0 || j > 0) {
    if (i > 0 && j > 0 && cost[at(i, j)] == cost[at(i - 1, j - 1)] + (ref[i - 1] == hyp[j - 1] ? 0 : 1)) {
      if (ref[i - 1] != hyp[j - 1]) ++errors.substitutions;
      --i;
      --j;
    } else if (i > 0 && cost[at(i, j)] == cost[at(i - 1, j)] + 1) {
      ++errors.deletions;
      --i;
    } else {
      ++errors.insertions;
      --j;
    }
  }
  return errors;
}

}  // namespace urs::devices
