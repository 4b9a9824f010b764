// Step tables: the rules shared by the CSV and JSON readers, diff, and the
// register ranges restore writes. The formats themselves are in
// step_table_csv.cpp and step_table_json.cpp.

#include "lec6/lec/step_table.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>

#include "lec/step_table_internal.hpp"
#include "lec6/lec/equipment_name.hpp"
#include "lec6/lec/units.hpp"

namespace lec6::lec {
namespace detail {

std::string_view trim(std::string_view s) {
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.remove_suffix(1);
  return s;
}

std::string lower(std::string_view s) {
  std::string out(s);
  for (char& c : out) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

namespace {

// Is this cell a zero for its field, as in a blank step's row?
bool is_zero(StepField f, std::string_view text) {
  if (f == StepField::MovementMode) {
    const std::string t = lower(text);
    return t == "0" || t == "blank";
  }
  const auto v = field_info(f).is_length ? parse_mm(text) : parse_integer(text);
  return v && *v == 0;
}

// parse_field names the field by its CLI name; name it as the file does.
std::string relabel(std::string message, std::string_view name, std::string_view label) {
  if (message.size() > name.size() && message.compare(0, name.size(), name) == 0 &&
      (message[name.size()] == ' ' || message[name.size()] == ':')) {
    message.replace(0, name.size(), label);
  }
  return message;
}

}  // namespace

std::optional<StepData> parse_step_cells(const StepCells& cells, std::string_view where,
                                         TableErrors& errors) {
  const bool complete = std::all_of(cells.text.begin(), cells.text.end(),
                                    [](const auto& t) { return t.has_value(); });
  if (complete) {
    bool blank = true;
    for (const auto& i : step_fields()) {
      blank = blank && is_zero(i.field, trim(*cells.text[static_cast<std::size_t>(i.field)]));
    }
    if (blank) return StepData{};
  }

  StepData s;
  bool ok = complete;
  for (const auto& i : step_fields()) {
    const auto n = static_cast<std::size_t>(i.field);
    if (!cells.text[n]) continue;
    const std::string_view text = trim(*cells.text[n]);
    const std::string& label = cells.labels[n];
    if (text.empty()) {
      errors.push_back(fmt::format("{}: {} is empty", where, label));
      ok = false;
      continue;
    }
    const auto v = parse_field(i.field, text);
    if (!v) {
      std::string msg = relabel(v.error(), i.name, label);
      if (i.field == StepField::MovementMode && is_zero(i.field, text)) {
        msg += " (mode 0 is only for a blank step: a row of all zeros)";
      }
      errors.push_back(fmt::format("{}: {}", where, msg));
      ok = false;
      continue;
    }
    set_field(s, i.field, *v);
  }
  if (!ok) return std::nullopt;
  const auto issues = validate(s);
  for (const auto& issue : issues) errors.push_back(fmt::format("{}: {}", where, issue.message));
  if (!issues.empty()) return std::nullopt;
  return s;
}

Expected<unsigned, std::string> parse_step_number(std::string_view text) {
  const auto v = parse_integer(trim(text));
  if (!v) return unexpected(fmt::format("step '{}' is not a step number (0 to 63)", trim(text)));
  if (*v < 0 || *v >= static_cast<int64_t>(StepTable::kSteps)) {
    return unexpected(fmt::format("step {} is out of range: allowed 0 to 63", *v));
  }
  return static_cast<unsigned>(*v);
}

Expected<std::string, std::string> parse_equipment_name(std::string_view text) {
  auto name = EquipmentName::make(trim(text));
  if (!name) return unexpected(name.error());
  return name->text;
}

Expected<uint8_t, std::string> parse_controller_id(std::string_view text) {
  const auto v = parse_integer(trim(text));
  if (!v || *v < 0 || *v > 255) {
    return unexpected(fmt::format(
        "controller_id '{}' is not a controller ID: allowed 1 to 255, or 0 for not recorded",
        trim(text)));
  }
  return static_cast<uint8_t>(*v);
}

std::string known_columns() {
  std::string out = "step";
  for (const auto& i : step_fields()) out += fmt::format(", {}", i.csv_column);
  return out + " (or the fields' CLI or manual names)";
}

TableBuilder::TableBuilder() {
  table_.covered.reset();
}

void TableBuilder::add(unsigned step, const std::optional<StepData>& data, std::string where,
                       TableErrors& errors) {
  ++rows_;
  if (!seen_at_[step].empty()) {
    errors.push_back(fmt::format("{}: step {} repeats {}", where, step, seen_at_[step]));
    return;
  }
  seen_at_[step] = std::move(where);
  table_.covered.set(step);
  if (data) table_.steps[step] = *data;
}

}  // namespace detail

std::vector<unsigned> StepTable::covered_steps() const {
  std::vector<unsigned> out;
  for (unsigned s = 0; s < kSteps; ++s) {
    if (covered.test(s)) out.push_back(s);
  }
  return out;
}

TableFormat table_format_for_path(std::string_view path) {
  const std::string p = detail::lower(path);
  return p.size() >= 5 && p.compare(p.size() - 5, 5, ".json") == 0 ? TableFormat::Json
                                                                   : TableFormat::Csv;
}

std::string format_table(const StepTable& table, TableFormat format) {
  return format == TableFormat::Json ? to_json(table) : to_csv(table);
}

Expected<StepTable, TableErrors> parse_table(std::string_view text, TableFormat format) {
  return format == TableFormat::Json ? parse_json(text) : parse_csv(text);
}

std::vector<StepFieldDiff> diff(const StepTable& a, const StepTable& b) {
  std::vector<StepFieldDiff> out;
  for (unsigned s = 0; s < StepTable::kSteps; ++s) {
    if (!a.covers(s) || !b.covers(s)) continue;
    for (const auto& i : step_fields()) {
      const int64_t va = get_field(a.steps[s], i.field);
      const int64_t vb = get_field(b.steps[s], i.field);
      if (va != vb)
        out.push_back({s, i.field, format_field(i.field, va), format_field(i.field, vb)});
    }
  }
  return out;
}

namespace {

// Width on screen of UTF-8 text (units like "mm/s²"), in code points.
std::size_t display_width(std::string_view s) {
  return static_cast<std::size_t>(std::count_if(
      s.begin(), s.end(), [](char c) { return (static_cast<unsigned char>(c) & 0xC0) != 0x80; }));
}

std::string pad(std::string_view s, std::size_t width) {
  std::string out(s);
  const std::size_t w = display_width(s);
  if (w < width) out.append(width - w, ' ');
  return out;
}

}  // namespace

std::string format_diff_side_by_side(const std::vector<StepFieldDiff>& diffs,
                                     std::string_view label_a, std::string_view label_b) {
  if (diffs.empty()) return "no differences\n";
  struct Row {
    std::string step, field, a, b;
  };
  std::vector<Row> rows{{"step", "field", std::string(label_a), std::string(label_b)}};
  for (const auto& d : diffs) {
    const auto& i = field_info(d.field);
    rows.push_back({fmt::format("{}", d.step),
                    i.unit.empty() ? std::string(i.name) : fmt::format("{} ({})", i.name, i.unit),
                    d.value_a, d.value_b});
  }
  std::size_t w_step = 0, w_field = 0, w_a = 0;
  for (const auto& r : rows) {
    w_step = std::max(w_step, display_width(r.step));
    w_field = std::max(w_field, display_width(r.field));
    w_a = std::max(w_a, display_width(r.a));
  }
  std::string out;
  for (const auto& r : rows) {
    out += std::string(w_step - display_width(r.step), ' ') + r.step + "  " +
           pad(r.field, w_field) + "  " + pad(r.a, w_a) + "  " + r.b;
    while (!out.empty() && out.back() == ' ') out.pop_back();
    out += '\n';
  }
  return out;
}

std::optional<RegisterRange> registers_that_differ(const StepData& have, const StepData& want) {
  const auto h = have.to_registers();
  const auto w = want.to_registers();
  std::optional<RegisterRange> range;
  for (unsigned i = 0; i < StepData::kRegisters; ++i) {
    if (h[i] == w[i]) continue;
    if (!range) range = RegisterRange{i, i};
    range->last = i;
  }
  return range;
}

}  // namespace lec6::lec
