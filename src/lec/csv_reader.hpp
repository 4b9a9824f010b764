#pragma once
// An RFC 4180 CSV reader as a state machine over the whole text, so a quoted
// cell may hold separators, doubled quotes ("") and line breaks, as
// spreadsheets write them. Used by the step-table reader (step_table_csv.cpp).
//
// What it accepts beyond the RFC, as spreadsheets save: LF or CRLF line ends
// (a CRLF inside quotes reads as LF), spaces and tabs around cells (dropped,
// unless the tab is the separator), blank space around a quoted cell. A
// UTF-8 BOM is the caller's to strip.

#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

namespace lec6::lec::csv {

struct Record {
  std::size_t line = 0;            // where the record starts, 1-based
  std::string_view raw;            // its text, line end excluded
  std::vector<std::string> cells;  // unquoted, trimmed
  // Empty, or why the record is malformed ("cell 3 has text after its closing
  // quote"); the reader then skips to the record's end and carries on.
  std::string error;
};

// Splits `text` into records. Each character of `separators` separates
// cells: one when the separator is known; several to find record boundaries
// and raw text before it is (the cells are then not meaningful).
std::vector<Record> read(std::string_view text, std::string_view separators);

}  // namespace lec6::lec::csv
