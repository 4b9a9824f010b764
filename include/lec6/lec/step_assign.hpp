#pragma once
// `lec step set N field=value ...`: parse the assignments and apply them to a
// step record. Pure: the caller reads the current record (and the --from
// record) from the controller and writes the result.
//
// Rules:
// - Field names are found with find_step_field (case-insensitive; CLI name,
//   the manual's long name or the CSV column). An unknown name lists the
//   known fields and suggests the closest one within edit distance 2.
// - Values go through parse_field (the manual's ranges, mm with two decimals).
// - A field given twice is an error, even with the same value.
// - A blank base (all registers 0) starts from default_step_data()
//   (step_defaults.hpp), the one set of defaults of moves, PUT /steps/N and
//   the dashboard; AssignResult::defaulted lists the fields it filled.
// - The result must pass validate(); cross-field rules (trigger ≤ pushing force) apply to every result, so a
//   step is never written in a state the controller would refuse to start.
// - --from M starts from step M's record instead of the step's own; a blank
//   step M is refused. With --from, no assignment is needed (a plain copy).
// - All or nothing: on any error there is no result; every error is reported.
//
// Thread safety: pure functions.

#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "lec6/expected.hpp"
#include "lec6/lec/step_data.hpp"

namespace lec6::lec {

struct StepAssignment {
  StepField field;
  int64_t raw;  // in the record's units (0.01 mm for lengths)
  bool operator==(const StepAssignment&) const = default;
};

using AssignErrors = std::vector<std::string>;

// "speed=500", "Position=-12.5", "pushing_speed=20". No arguments → an empty
// list (apply_assignments decides whether that is enough).
Expected<std::vector<StepAssignment>, AssignErrors> parse_assignments(
    std::span<const std::string> args);
Expected<StepAssignment, std::string> parse_assignment(std::string_view arg);

// "unknown field 'spede': did you mean 'speed'? known fields are mode, speed, ..."
std::string unknown_field_message(std::string_view name);

// The record to start from instead of the step's current one (--from M).
struct CopySource {
  unsigned step;
  StepData data;
};

struct AssignResult {
  StepData step;
  std::vector<StepField> changed;  // fields that differ from `current`, register order
  // A blank step: the fields the defaults filled (not given, not 0), register order.
  std::vector<StepField> defaulted;
  // Legal but likely a mistake, e.g. a moving force of 0 %; to show the user.
  std::vector<std::string> warnings;
};

// Applies the assignments to `current` (or to `from`'s record), checks the
// result, and lists what changed relative to `current`. `step` is the step
// number, used in messages.
Expected<AssignResult, AssignErrors> apply_assignments(unsigned step, const StepData& current,
                                                       std::span<const StepAssignment> assignments,
                                                       const std::optional<CopySource>& from = {});

// parse_assignments + apply_assignments, errors of both kinds together.
Expected<AssignResult, AssignErrors> assign_step(unsigned step, const StepData& current,
                                                 std::span<const std::string> args,
                                                 const std::optional<CopySource>& from = {});

}  // namespace lec6::lec
