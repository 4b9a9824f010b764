#pragma once
// `lec step` output: steps, changes, restore reports and diffs as text,
// tables and JSON (step_views.cpp). The commands are cmd_step.cpp.

#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "cli/json_output.hpp"
#include "lec6/client/step_sync.hpp"
#include "lec6/lec/step_data.hpp"
#include "lec6/lec/step_table.hpp"

namespace lec6::cli {

// ---- text ----
// "\n  e1\n  e2": errors as an indented list to append to a message.
std::string errors_text(const std::vector<std::string>& errors);
// "1 error", "3 errors".
std::string count_text(std::size_t n, std::string_view one, std::string_view many);
// "D0432-D0433" for registers 2-3 of step 3.
std::string register_text(unsigned step, const lec::RegisterRange& r);
// "speed 500 -> 600, position 150.00 -> 160.00"; "new step (was blank)"; "made blank".
std::string change_text(const client::StepChange& c);

// ---- JSON ----
// {"step": 0, "mode": "abs", "speed_mm_s": 500, "position_mm": 150.00, ...}: the CSV columns.
nlohmann::json step_json(unsigned step, const lec::StepData& s);
nlohmann::json change_json(const client::StepChange& c);
nlohmann::json report_json(const client::RestoreReport& r);
nlohmann::json diff_json(const client::StepDiff& d, std::string_view a, std::string_view b);

// ---- reports ----
// One step's outcome as a line (nothing for unchanged and not attempted steps).
void print_step_result(const client::StepResult& r);
// What was written, not attempted and unchanged, the wear line, and how to finish a partial
// restore.
void print_report_tail(const client::RestoreReport& r);
// One step, every field with its unit, and its validation warnings.
void print_step(unsigned n, const lec::StepData& d);
// The steps `shown` as a table: a header with the field names, one with the units.
void print_step_table(const client::StepRecords& steps, const std::vector<unsigned>& shown);

}  // namespace lec6::cli
