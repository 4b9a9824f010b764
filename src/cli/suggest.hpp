#pragma once
// "Did you mean": an unknown command gets the nearest known one, instead of
// CLI11's "A subcommand is required" / "The following arguments were not
// expected" (issue 17).

#include <CLI/CLI.hpp>

#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace lec6::cli {

// Edit distance: insertions, deletions, substitutions and swaps of two
// neighbouring letters, each 1.
std::size_t edit_distance(std::string_view a, std::string_view b);

// The name among `names` closest to `typed`, when it is close enough to be a
// typo (at most 2 edits, and fewer than half the letters); nullopt otherwise.
std::optional<std::string> nearest(std::string_view typed, const std::vector<std::string>& names);

// When argv names a command `app` does not have: the message to print
// ("unknown command 'stauts': did you mean 'status'? ..."); nullopt when the
// command word is a known command or there is none.
std::optional<std::string> unknown_command_message(const CLI::App& app, int argc,
                                                   const char* const* argv);

}  // namespace lec6::cli
