#pragma once
// One duration syntax for every time option of `lec`: a number and a unit,
// `500ms`, `2s`, `1.5s`, `250us`, `2min` (docs/protocol-decisions.md, "CLI
// durations"). Older spellings keep working for a while, each with a hint that
// names the new one:
//   - a bare number where the option used to take one (`--for 5`, `watch
//     --interval 100`) means the old unit;
//   - a renamed option (`--timeout-s 2`, `--delay-ms 5`) still sets the new one.

#include <CLI/CLI.hpp>

#include <string>
#include <string_view>

#include "lec6/clock.hpp"

namespace lec6::cli {

// What a number without a unit means for this option.
enum class BareNumber {
  Refused,       // a unit is required (a new option, or one whose bare number meant else)
  Milliseconds,  // the option took ms before: accepted, with a deprecation hint
  Seconds,       // the option took seconds before: accepted, with a deprecation hint
};

struct DurationLimits {
  Duration min{};
  Duration max{};
  Duration resolution{};  // e.g. whole ms for a kernel setting; 0 = any
};

struct DurationText {
  Duration value{};   // a bare number is read as seconds here
  double number = 0;  // as typed, before its unit
  bool had_unit = false;
};

// "500ms" → 500 ms. Throws InvalidArgument naming the accepted forms.
DurationText parse_duration(std::string_view text);

// The shortest exact spelling: 60 s → "60s", 0.5 s → "500ms", 1.5 s → "1.5s".
std::string format_duration(Duration d);

// OPTION DURATION: parses into `out`, checks `limits`, and shows the current
// value of `out` as the default in --help.
CLI::Option* add_duration_option(CLI::App* app, const std::string& name, Duration& out,
                                 const std::string& help, DurationLimits limits,
                                 BareNumber bare = BareNumber::Refused);

// A renamed option that takes a number in `unit`: sets `out` as `new_name`
// would, prints "OLD N is deprecated; write NEW Nunit", and is hidden from
// --help. `hint` replaces the usual words when the rename needs explaining.
CLI::Option* add_renamed_duration_option(CLI::App* app, const std::string& old_name,
                                         const std::string& new_name, Duration& out,
                                         BareNumber unit, DurationLimits limits,
                                         std::string hint = {});

// `--timeout DURATION`, the deadline of a wait (servo, home, move, follow),
// with the old `--timeout-s SECONDS` kept as a renamed option.
CLI::Option* add_deadline_option(CLI::App* app, Duration& out, const std::string& help);

}  // namespace lec6::cli
