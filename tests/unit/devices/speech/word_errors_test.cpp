#include "urs/devices/word_errors.hpp"

#include <gtest/gtest.h>

namespace urs::devices {
namespace {

TEST(WordErrors, CountsEachKindOfError) {
  const auto same = align_words("go to the kitchen", "Go  to the KITCHEN");
  EXPECT_EQ(same.errors(), 0u);
  EXPECT_EQ(same.reference_words, 4u);

  const auto substituted = align_words("turn left", "turn right");
  EXPECT_EQ(substituted.substitutions, 1u);
  EXPECT_DOUBLE_EQ(substituted.rate(), 0.5);

  const auto deleted = align_words("go to the kitchen", "go kitchen");
  EXPECT_EQ(deleted.deletions, 2u);
  EXPECT_EQ(deleted.errors(), 2u);

  const auto inserted = align_words("stop", "stop stop now");
  EXPECT_EQ(inserted.insertions, 2u);
  EXPECT_DOUBLE_EQ(inserted.rate(), 2.0);

  const auto nothing_heard = align_words("speak louder", "");
  EXPECT_EQ(nothing_heard.deletions, 2u);
  EXPECT_DOUBLE_EQ(align_words("", "").rate(), 0.0);
}

TEST(WordErrors, AddsUpOverUtterances) {
  WordErrors total;
  total += align_words("turn left", "turn left");
  total += align_words("go forward", "go back");
  total += align_words("stop", "");
  EXPECT_EQ(total.reference_words, 5u);
  EXPECT_EQ(total.substitutions, 1u);
  EXPECT_EQ(total.deletions, 1u);
  EXPECT_DOUBLE_EQ(total.rate(), 0.4);
}

}  // namespace
}  // namespace urs::devices
