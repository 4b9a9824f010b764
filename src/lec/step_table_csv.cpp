// Step tables as CSV. The format and what the reader accepts are described
// in include/lec6/lec/step_table.hpp.

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <optional>

#include "lec/csv_reader.hpp"
#include "lec/step_table_internal.hpp"
#include "lec6/lec/step_table.hpp"

namespace lec6::lec {
namespace {

using detail::lower;
using detail::trim;

constexpr std::string_view kBom = "\xEF\xBB\xBF";

// A comment line as the writer puts it: quoted as one CSV field when it holds
// a character a spreadsheet would split on or unquote.
std::string comment_line(std::string_view text) {
  if (text.find_first_of(",;\t\"\r\n") == std::string_view::npos) return std::string(text);
  std::string out = "\"";
  for (char c : text) {
    out += c;
    if (c == '"') out += '"';
  }
  return out + "\"";
}

// A comment record: its first cell starts with '#'.
bool is_comment(const csv::Record& r) {
  if (r.cells.empty()) return false;
  const std::string_view first = trim(r.cells.front());
  return !first.empty() && first.front() == '#';
}

// Separators from the header record's text: the first ';' outside quotes
// wins, else a tab, else ','.
char detect_separator(std::string_view header) {
  bool quoted = false;
  bool tab = false;
  for (char c : header) {
    if (c == '"') quoted = !quoted;
    if (quoted) continue;
    if (c == ';') return ';';
    if (c == '\t') tab = true;
  }
  return tab ? '\t' : ',';
}

bool all_empty(const std::vector<std::string>& cells) {
  return std::all_of(cells.begin(), cells.end(),
                     [](const std::string& c) { return trim(c).empty(); });
}

// The text of a comment, '#' dropped; cells a spreadsheet split it into are
// joined back with the separator.
std::string comment_text(std::vector<std::string> cells, char sep) {
  while (cells.size() > 1 && trim(cells.back()).empty()) cells.pop_back();
  std::string text;
  for (std::size_t i = 0; i < cells.size(); ++i) {
    if (i > 0) text += sep;
    text += cells[i];
  }
  std::string_view t = trim(text);
  t.remove_prefix(1);  // '#'
  return std::string(trim(t));
}

struct Columns {
  std::optional<std::size_t> step;
  std::array<std::optional<std::size_t>, kStepFieldCount> field;
  std::array<std::string, kStepFieldCount> label;
  std::vector<std::size_t> unnamed;
  std::size_t width = 0;
};

Columns read_header(const std::vector<std::string>& cells, std::size_t line, TableErrors& errors) {
  Columns cols;
  cols.width = cells.size();
  std::vector<std::string> unknown;
  for (std::size_t j = 0; j < cells.size(); ++j) {
    const std::string name(trim(cells[j]));
    if (name.empty()) {
      cols.unnamed.push_back(j);
      continue;
    }
    if (lower(name) == "step") {
      if (cols.step) {
        errors.push_back(fmt::format("line {}: column 'step' appears twice", line));
      }
      cols.step = j;
      continue;
    }
    const StepFieldInfo* info = find_step_field(name);
    if (!info) {
      unknown.push_back(fmt::format("'{}'", name));
      continue;
    }
    const auto n = static_cast<std::size_t>(info->field);
    if (cols.field[n]) {
      errors.push_back(fmt::format("line {}: columns '{}' and '{}' are both {}", line,
                                   cols.label[n], name, info->csv_column));
      continue;
    }
    cols.field[n] = j;
    cols.label[n] = name;
  }
  if (!unknown.empty()) {
    errors.push_back(fmt::format("line {}: unknown column{} {}: known columns are {}", line,
                                 unknown.size() > 1 ? "s" : "", fmt::join(unknown, ", "),
                                 detail::known_columns()));
  }
  std::vector<std::string_view> missing;
  if (!cols.step) missing.push_back("step");
  for (const auto& i : step_fields()) {
    if (!cols.field[static_cast<std::size_t>(i.field)]) missing.push_back(i.csv_column);
  }
  if (!missing.empty()) {
    errors.push_back(fmt::format("line {}: missing column{} {}", line,
                                 missing.size() > 1 ? "s" : "", fmt::join(missing, ", ")));
  }
  return cols;
}

}  // namespace

std::string to_csv(const StepTable& table) {
  std::string out;
  out += comment_line(fmt::format("# equipment_name: {}", table.equipment_name)) + "\n";
  out += fmt::format("# controller_id: {}\n", table.controller_id);
  out += "step";
  for (const auto& i : step_fields()) out += fmt::format(",{}", i.csv_column);
  out += '\n';
  for (unsigned s = 0; s < StepTable::kSteps; ++s) {
    if (!table.covers(s)) continue;
    const StepData& d = table.steps[s];
    out += fmt::format("{}", s);
    for (const auto& i : step_fields()) {
      out += ',';
      if (i.field == StepField::MovementMode && d.movement_mode == MovementMode::Blank) {
        out += '0';
      } else {
        out += format_field(i.field, get_field(d, i.field));
      }
    }
    out += '\n';
  }
  return out;
}

Expected<StepTable, TableErrors> parse_csv(std::string_view text) {
  TableErrors errors;
  if (text.starts_with("\xFF\xFE") || text.starts_with("\xFE\xFF") ||
      text.find('\0') != std::string_view::npos) {
    return unexpected(TableErrors{
        "the file is not UTF-8 text (UTF-16?): save it as CSV UTF-8 (comma or semicolon)"});
  }
  if (text.starts_with(kBom)) text.remove_prefix(kBom.size());

  // The header: the first record with content (not only separators) that is
  // not a comment. Record boundaries depend on quotes, not on which separator
  // is used, so any of them finds it; its text then tells the separator.
  const std::vector<csv::Record> any = csv::read(text, ",;\t");
  const auto header_it = std::find_if(any.begin(), any.end(), [](const csv::Record& r) {
    return r.raw.find_first_not_of(" \t,;\"") != std::string_view::npos && !is_comment(r);
  });
  if (header_it == any.end()) {
    return unexpected(TableErrors{"no header line: the file needs a header naming its columns (" +
                                  detail::known_columns() + ")"});
  }
  const std::size_t header_line = header_it->line;
  const char sep = detect_separator(header_it->raw);
  const std::vector<csv::Record> records = csv::read(text, std::string_view(&sep, 1));

  std::optional<Columns> cols;
  std::optional<std::string> name;
  std::optional<uint8_t> id;
  std::size_t name_line = 0, id_line = 0;
  detail::TableBuilder builder;

  for (const csv::Record& record : records) {
    const std::size_t line = record.line;
    if (!record.error.empty()) {
      errors.push_back(fmt::format("line {}: {}", line, record.error));
      if (!cols && line == header_line) return unexpected(std::move(errors));
      continue;
    }
    const std::vector<std::string>* cells = &record.cells;
    if (all_empty(*cells)) continue;

    const std::string_view first = trim(cells->front());
    if (!first.empty() && first.front() == '#') {
      const std::string comment = comment_text(*cells, sep);
      const auto colon = comment.find(':');
      if (colon == std::string::npos) continue;
      const std::string key = lower(trim(std::string_view(comment).substr(0, colon)));
      const std::string_view value = trim(std::string_view(comment).substr(colon + 1));
      if (key == "equipment_name" || key == "controller_id") {
        std::size_t& seen = key == "equipment_name" ? name_line : id_line;
        if (seen != 0) {
          errors.push_back(
              fmt::format("line {}: {} is given again (first on line {})", line, key, seen));
          continue;
        }
        seen = line;
        if (key == "equipment_name") {
          auto v = detail::parse_equipment_name(value);
          if (v) {
            name = *v;
          } else {
            errors.push_back(fmt::format("line {}: {}", line, v.error()));
          }
        } else {
          auto v = detail::parse_controller_id(value);
          if (v) {
            id = *v;
          } else {
            errors.push_back(fmt::format("line {}: {}", line, v.error()));
          }
        }
      }
      continue;
    }

    if (!cols) {
      cols = read_header(*cells, line, errors);
      if (!cols->step) return unexpected(std::move(errors));
      continue;
    }

    // A step row.
    const auto cell = [&](std::size_t j) -> std::optional<std::string> {
      return j < cells->size() ? std::optional<std::string>((*cells)[j]) : std::nullopt;
    };
    const auto step = detail::parse_step_number(cell(*cols->step).value_or(""));
    const std::string where =
        step ? fmt::format("line {} (step {})", line, *step) : fmt::format("line {}", line);
    if (!step) errors.push_back(fmt::format("line {}: {}", line, step.error()));
    for (std::size_t j = cols->width; j < cells->size(); ++j) {
      if (!trim((*cells)[j]).empty()) {
        errors.push_back(fmt::format("{}: cell {} ('{}') is past the header's {} columns", where,
                                     j + 1, (*cells)[j], cols->width));
      }
    }
    for (std::size_t j : cols->unnamed) {
      if (j < cells->size() && !trim((*cells)[j]).empty()) {
        errors.push_back(fmt::format("{}: cell {} ('{}') is under a column with no name", where,
                                     j + 1, (*cells)[j]));
      }
    }
    detail::StepCells sc;
    for (std::size_t n = 0; n < kStepFieldCount; ++n) {
      sc.labels[n] = cols->label[n];
      if (cols->field[n]) sc.text[n] = cell(*cols->field[n]).value_or("");
    }
    const auto data = detail::parse_step_cells(sc, where, errors);
    if (step) builder.add(*step, data, fmt::format("line {}", line), errors);
  }

  if (!cols) {
    errors.push_back("no header line: the file needs a header naming its columns (" +
                     detail::known_columns() + ")");
  } else if (builder.empty()) {
    errors.push_back("the file has no step rows");
  }
  if (!errors.empty()) return unexpected(std::move(errors));
  StepTable table = std::move(builder.table());
  table.equipment_name = name.value_or("");
  table.controller_id = id.value_or(0);
  return table;
}

}  // namespace lec6::lec
