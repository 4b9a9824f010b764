#pragma once
// Shared by the CSV and JSON readers of step tables: the rules for one step's
// values, the step number, the metadata and the table being assembled, so the
// two formats validate the same way and word their errors the same way.

#include <array>
#include <optional>
#include <string>
#include <string_view>

#include "lec6/lec/step_data.hpp"
#include "lec6/lec/step_table.hpp"

namespace lec6::lec::detail {

std::string_view trim(std::string_view s);
std::string lower(std::string_view s);

// One step's cells, indexed by StepField; nullopt when the file has no
// column/key for that field. `labels` are the names the file used, for errors.
struct StepCells {
  std::array<std::optional<std::string>, kStepFieldCount> text;
  std::array<std::string, kStepFieldCount> labels;
};

// The record, or nullopt with the errors appended, each prefixed by `where`
// ("line 5 (step 3)"). A row of zeros is a blank step; any other row must
// parse field by field and pass validate(). Cells of missing columns are not
// reported (the header error covers them) but the row then yields nothing.
std::optional<StepData> parse_step_cells(const StepCells& cells, std::string_view where,
                                         TableErrors& errors);

// "3" → 3; the error explains the allowed range.
Expected<unsigned, std::string> parse_step_number(std::string_view text);
Expected<std::string, std::string> parse_equipment_name(std::string_view text);
Expected<uint8_t, std::string> parse_controller_id(std::string_view text);

// "step, mode, speed_mm_s, ..." for messages about unknown columns/keys.
std::string known_columns();

// Collects steps, refusing repeats; `where` names the source of each step
// ("line 5", "steps[2]") for the repeat message.
class TableBuilder {
 public:
  TableBuilder();
  void add(unsigned step, const std::optional<StepData>& data, std::string where,
           TableErrors& errors);
  bool empty() const { return rows_ == 0; }
  StepTable& table() { return table_; }

 private:
  StepTable table_;
  std::array<std::string, StepTable::kSteps> seen_at_;
  std::size_t rows_ = 0;
};

}  // namespace lec6::lec::detail
