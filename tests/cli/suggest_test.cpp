// "Did you mean": the nearest command for a typo, nothing for a word far from all
// (the rule itself: tests/lec/nearest_test.cpp).

#include "cli/suggest.hpp"

#include <gtest/gtest.h>

namespace lec6::cli {
namespace {

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
