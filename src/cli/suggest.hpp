#pragma once
// "Did you mean": an unknown command gets the nearest known one, instead of
// CLI11's "A subcommand is required" / "The following arguments were not
// expected" (issue 17). The rule for what counts as a typo is lec::nearest's
// (lec6/lec/nearest.hpp), the same for commands, step fields and config keys.

#include <CLI/CLI.hpp>

#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace lec6::cli {

// When argv names a command `app` does not have: the message to print
// ("unknown command 'stauts': did you mean 'status'? ..."); nullopt when the
// command word is a known command or there is none.
std::optional<std::string> unknown_command_message(const CLI::App& app, int argc,
                                                   const char* const* argv);

}  // namespace lec6::cli
