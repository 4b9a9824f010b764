// "Did you mean": the nearest command for a typo, nothing for a word far from all.

#include "cli/suggest.hpp"

#include <gtest/gtest.h>

namespace lec6::cli {
namespace {

TEST(Suggest, EditDistanceCountsInsertionsDeletionsSubstitutionsAndSwaps) {
  EXPECT_EQ(edit_distance("status", "status"), 0u);
  EXPECT_EQ(edit_distance("stauts", "status"), 1u);  // two neighbours swapped
  EXPECT_EQ(edit_distance("satus", "status"), 1u);
  EXPECT_EQ(edit_distance("stop", "step"), 1u);
  EXPECT_EQ(edit_distance("hom", "home"), 1u);
  EXPECT_EQ(edit_distance("", "move"), 4u);
}

TEST(Suggest, NearestIsATypoNotAGuess) {
  const std::vector<std::string> names{"status", "move", "home", "serve", "sim", "step"};
  EXPECT_EQ(nearest("stauts", names), "status");
  EXPECT_EQ(nearest("mvoe", names), "move");
  EXPECT_EQ(nearest("serv", names), "serve");
  EXPECT_EQ(nearest("frobnicate", names), std::nullopt);
  EXPECT_EQ(nearest("xy", names), std::nullopt);  // too short to tell a typo from another word
}

TEST(Suggest, TheCommandWordSkipsOptionsAndTheirValues) {
  CLI::App app;
  std::string port;
  app.add_option("--port", port);
  app.add_flag("--json");
  app.add_subcommand("status");
  app.add_subcommand("move");
  const char* typo[] = {"lec", "--port", "sim", "--json", "stauts"};
  EXPECT_EQ(unknown_command_message(app, 5, typo),
            "unknown command 'stauts': did you mean 'status'? (`lec --help` lists the commands)");
  const char* known[] = {"lec", "--port", "status", "move"};  // "status" is --port's value
  EXPECT_EQ(unknown_command_message(app, 4, known), std::nullopt);
  const char* none[] = {"lec", "--json"};
  EXPECT_EQ(unknown_command_message(app, 2, none), std::nullopt);
}

}  // namespace
}  // namespace lec6::cli
