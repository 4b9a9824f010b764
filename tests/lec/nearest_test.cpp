// "Did you mean": one rule for commands, step fields and config keys.

#include "lec6/lec/nearest.hpp"

#include <gtest/gtest.h>

namespace lec6::lec {
namespace {

TEST(Nearest, EditDistanceCountsInsertionsDeletionsSubstitutionsAndSwaps) {
  EXPECT_EQ(edit_distance("status", "status"), 0u);
  EXPECT_EQ(edit_distance("stauts", "status"), 1u);  // two neighbours swapped
  EXPECT_EQ(edit_distance("satus", "status"), 1u);
  EXPECT_EQ(edit_distance("stop", "step"), 1u);
  EXPECT_EQ(edit_distance("hom", "home"), 1u);
  EXPECT_EQ(edit_distance("", "move"), 4u);
}

TEST(Nearest, IsATypoNotAGuess) {
  const std::vector<std::string> names{"status", "move", "home", "serve", "sim", "step"};
  EXPECT_EQ(nearest("stauts", names), "status");
  EXPECT_EQ(nearest("mvoe", names), "move");
  EXPECT_EQ(nearest("serv", names), "serve");
  EXPECT_EQ(nearest("frobnicate", names), std::nullopt);
  EXPECT_EQ(nearest("xy", names), std::nullopt);  // too short to tell a typo from another word
}

TEST(Nearest, ALongerOrShorterSpellingOfANameIsMeantToo) {
  const std::vector<std::string> keys{"name", "port", "baud", "silent_interval", "retries"};
  EXPECT_EQ(nearest("baudrate", keys), "baud");
  EXPECT_EQ(nearest("silent", keys), "silent_interval");
  EXPECT_EQ(nearest("po", keys), std::nullopt);  // a prefix needs 3 letters
  // A close spelling wins over a prefix: "push" is a prefix of "pushing_sped".
  EXPECT_EQ(nearest("pushing_sped", {"push", "pushing_speed"}), "pushing_speed");
  EXPECT_EQ(nearest_index("retires", keys), 4u);
}

}  // namespace
}  // namespace lec6::lec
