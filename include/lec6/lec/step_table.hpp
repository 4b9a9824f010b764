#pragma once
// The controller's program as a file: the 64 step-data records (§10.4) plus
// the equipment name and controller ID they were read from. Pure: no device
// I/O. Used by `lec step backup / restore / diff`.
//
// CSV layout (what to_csv writes):
//
//   # equipment_name: LEC6-AXIS1
//   # controller_id: 1
//   step,mode,speed_mm_s,position_mm,accel_mm_s2,...,in_position_mm
//   0,abs,500,150.00,5000,5000,0,0,20,100,0.00,0.00,1.00
//   1,0,0,0.00,0,0,0,0,0,0,0.00,0.00,0.00          <- a blank step
//
// - Columns are the csv_column names of the field table (step_fields()), plus
//   `step`. Lengths are millimetres with two decimals; mode is abs / inc, and
//   a blank step (all 16 registers 0) is a row of zeros with mode 0.
// - The equipment name and controller ID travel in leading comment lines
//   (first cell starting with '#'). A spreadsheet shows each as one text cell
//   in column A above the header and writes it back unchanged, so the file
//   still opens and saves cleanly; the writer quotes the line as one CSV field
//   when the name contains ',', ';', '"' or a line break. Comment lines may appear anywhere
//   (so a step row can be commented out with '#'); ones without a known
//   `key:` are ignored; a known key given twice is an error. The name is informational (D000E
//   is read-only); leading/trailing spaces of it are not kept. controller_id 0
//   means "not recorded" (0 is the broadcast address, never a controller).
// - LF line ends, no BOM.
//
// What parse_csv accepts (a spreadsheet round trip):
// - a UTF-8 BOM; CRLF or LF line ends; empty lines and rows of only empty
//   cells anywhere (skipped); spaces around cells;
// - quoted cells ("150.00", "" for a quote), RFC 4180: a quoted cell may hold
//   the separator and line breaks (a comment written over two lines in a
//   spreadsheet cell); errors name the line its record starts on;
// - the separator detected from the header line: ';' if it has one outside
//   quotes, else a tab if it has one, else ','; decimal commas in lengths
//   ("150,00", as parse_mm accepts);
// - header columns in any order, any case, by CLI name, the manual's long
//   name or the CSV column (find_step_field); `step` is required and every
//   field column is required; unknown, repeated or missing columns are errors;
//   empty header cells are ignored if the cells under them are empty;
// - cells past the header's width only when empty (spreadsheet padding).
// UTF-16 files (Excel's "Unicode text") are refused with a hint.
//
// to_csv writes what the table holds. A backup of a controller holding steps
// that break the manual's ranges therefore writes them as they are, and
// parse_csv refuses that file naming each bad step: restore never writes a
// step that validate() rejects.
//
// Partial files are allowed: a file may list any subset of the 64 steps, in
// any order, each at most once. StepTable::covered records which steps the
// file lists, and restore writes only those. A file with no step rows is an
// error.
//
// Validation is all-or-nothing: every row and every field is checked, every
// error is reported (with line number, step and column), and no table is
// returned when there is any error. A row of zeros (mode 0 or "blank") is a
// blank step; any other row must parse field by field (parse_field: the
// manual's ranges) and then pass validate() (e.g. trigger ≤ pushing force).
//
// JSON has the same content and the same rules:
//   {"equipment_name": "LEC6-AXIS1", "controller_id": 1,
//    "steps": [{"step": 0, "mode": "abs", "speed_mm_s": 500, "position_mm": 150.00, ...}]}
// Lengths are JSON numbers in mm with two decimals; strings ("150.00") are
// accepted too. A blank step is written with "mode": "blank" and zeros
// (0 and "0" are accepted for the mode as well). Errors name the step's index
// in the array: "steps[4] (step 3): speed_mm_s ...". Unknown keys are errors.
//
// Thread safety: value types and pure functions; const objects may be shared between threads,
// writes need the caller's synchronisation.

#include <array>
#include <bitset>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "lec6/expected.hpp"
#include "lec6/lec/step_data.hpp"

namespace lec6::lec {

struct StepTable {
  static constexpr std::size_t kSteps = 64;

  std::array<StepData, kSteps> steps{};  // index = step number
  std::bitset<kSteps> covered{~0ULL};    // which steps the table holds (all by default)
  std::string equipment_name;            // as read from D000E; "" if unknown
  uint8_t controller_id = 0;             // 0 = not recorded

  bool covers(std::size_t step) const { return step < kSteps && covered.test(step); }
  std::vector<unsigned> covered_steps() const;
  bool operator==(const StepTable&) const = default;
};

// All the errors found, one message each, in file order.
using TableErrors = std::vector<std::string>;

// The CSV described above, covered steps only, in step order.
std::string to_csv(const StepTable& table);
Expected<StepTable, TableErrors> parse_csv(std::string_view text);

std::string to_json(const StepTable& table);
Expected<StepTable, TableErrors> parse_json(std::string_view text);

enum class TableFormat { Csv, Json };
// ".json" (any case) → Json; everything else → Csv.
TableFormat table_format_for_path(std::string_view path);
std::string format_table(const StepTable& table, TableFormat format);
Expected<StepTable, TableErrors> parse_table(std::string_view text, TableFormat format);

// One field of one step that differs between two tables, both values shown
// as format_field does ("abs", "150.00", "500").
struct StepFieldDiff {
  unsigned step;
  StepField field;
  std::string value_a;
  std::string value_b;
  bool operator==(const StepFieldDiff&) const = default;
};

// Differences for the steps both tables cover, in step then register order.
std::vector<StepFieldDiff> diff(const StepTable& a, const StepTable& b);

// A table for people, e.g. (label_a "device", label_b "backup.csv"):
//   step  field               device    backup.csv
//      3  speed (mm/s)        500       600
// or "no differences\n".
std::string format_diff_side_by_side(const std::vector<StepFieldDiff>& diffs,
                                     std::string_view label_a, std::string_view label_b);

// Register offsets 0–15 within one 16-register step record, inclusive.
struct RegisterRange {
  unsigned first;
  unsigned last;
  unsigned count() const { return last - first + 1; }
  bool operator==(const RegisterRange&) const = default;
};

// The smallest single range of registers covering every register that differs
// (one write transaction per step); nullopt when the records are equal.
std::optional<RegisterRange> registers_that_differ(const StepData& have, const StepData& want);

}  // namespace lec6::lec
