// `lec step` output: the text, tables and JSON of steps, changes, restore
// reports and diffs (the commands are cmd_step.cpp).

#include "cli/step_views.hpp"

#include <fmt/format.h>

#include <algorithm>

#include "lec6/lec/memory_map.hpp"

namespace lec6::cli {

using lec::StepData;
using lec::StepField;

namespace {

// Width on screen of UTF-8 text ("mm/s²"), in code points.
std::size_t display_width(std::string_view s) {
  return static_cast<std::size_t>(std::count_if(
      s.begin(), s.end(), [](char c) { return (static_cast<unsigned char>(c) & 0xC0) != 0x80; }));
}

std::string pad_left(std::string_view s, std::size_t width) {
  const std::size_t w = display_width(s);
  return std::string(w < width ? width - w : 0, ' ') + std::string(s);
}

std::string pad_right(std::string_view s, std::size_t width) {
  const std::size_t w = display_width(s);
  return std::string(s) + std::string(w < width ? width - w : 0, ' ');
}

std::string rtrim(std::string s) {
  while (!s.empty() && s.back() == ' ') s.pop_back();
  return s;
}

std::string field_text(const StepData& s, StepField f) {
  return lec::format_field(f, lec::get_field(s, f));
}

}  // namespace

// ---- text ------------------------------------------------------------------

std::string errors_text(const std::vector<std::string>& errors) {
  std::string out;
  for (const auto& e : errors) out += "\n  " + e;
  return out;
}

std::string count_text(std::size_t n, std::string_view one, std::string_view many) {
  return fmt::format("{} {}", n, n == 1 ? one : many);
}

std::string register_text(unsigned step, const lec::RegisterRange& r) {
  const unsigned a = lec::step_address(step) + r.first;
  const unsigned b = lec::step_address(step) + r.last;
  return a == b ? fmt::format("D{:04X}", a) : fmt::format("D{:04X}-D{:04X}", a, b);
}

std::string change_text(const client::StepChange& c) {
  if (c.have.is_blank()) return "new step (was blank)";
  if (c.want.is_blank()) return "made blank (the step was in use)";
  std::string out;
  for (StepField f : c.fields) {
    if (!out.empty()) out += ", ";
    out += fmt::format("{} {} -> {}", lec::field_info(f).name, field_text(c.have, f),
                       field_text(c.want, f));
  }
  return out;
}

// ---- JSON --------------------------------------------------------------------

namespace {
nlohmann::json field_json(const StepData& s, const lec::StepFieldInfo& i) {
  const int64_t v = lec::get_field(s, i.field);
  if (i.field == StepField::MovementMode) return lec::format_field(i.field, v);
  if (i.is_length) return mm_json(v);
  return v;
}

}  // namespace

nlohmann::json step_json(unsigned step, const StepData& s) {
  nlohmann::json j = nlohmann::json::object();
  j["step"] = step;
  for (const auto& i : lec::step_fields()) j[std::string(i.csv_column)] = field_json(s, i);
  return j;
}

nlohmann::json change_json(const client::StepChange& c) {
  nlohmann::json fields = nlohmann::json::array();
  for (StepField f : c.fields) {
    fields.push_back({{"field", lec::field_info(f).name},
                      {"from", field_text(c.have, f)},
                      {"to", field_text(c.want, f)}});
  }
  nlohmann::json j = {{"step", c.step}, {"fields", fields}};
  if (c.registers) {
    j["registers"] = {{"first", lec::step_address(c.step) + c.registers->first},
                      {"count", c.registers->count()},
                      {"text", register_text(c.step, *c.registers)}};
  }
  return j;
}

nlohmann::json report_json(const client::RestoreReport& r) {
  nlohmann::json steps = nlohmann::json::array();
  nlohmann::json failed = nlohmann::json::array();
  for (const auto& s : r.steps) {
    if (s.outcome == client::StepOutcome::Unchanged) continue;
    auto j = change_json(s.change);
    j["outcome"] = client::outcome_name(s.outcome);
    if (s.outcome == client::StepOutcome::Failed) {
      j["error"] = s.error;
      j["maybe_written"] = s.maybe_written;
      failed.push_back({{"step", s.change.step}, {"error", s.error}});
    }
    steps.push_back(j);
  }
  return {{"dry_run", r.dry_run},
          {"verified", r.verified},
          {"ok", r.ok()},
          {"steps", steps},
          {"written", r.steps_with(client::StepOutcome::Written)},
          {"to_write", r.steps_with(client::StepOutcome::Planned)},
          {"unchanged", r.steps_with(client::StepOutcome::Unchanged)},
          {"failed", failed},
          {"not_attempted", r.steps_with(client::StepOutcome::NotAttempted)},
          {"notes", r.notes},
          {"summary", r.summary()}};
}

nlohmann::json diff_json(const client::StepDiff& d, std::string_view a, std::string_view b) {
  nlohmann::json fields = nlohmann::json::array();
  for (const auto& f : d.fields) {
    fields.push_back({{"step", f.step},
                      {"field", lec::field_info(f.field).name},
                      {"a", f.value_a},
                      {"b", f.value_b}});
  }
  return {{"equal", d.equal()}, {"a", a}, {"b", b}, {"differences", fields}, {"notes", d.notes}};
}

// ---- reports ----

void print_step_result(const client::StepResult& r) {
  const auto& c = r.change;
  const std::string regs =
      c.registers ? fmt::format(" [{}]", register_text(c.step, *c.registers)) : "";
  switch (r.outcome) {
    case client::StepOutcome::Unchanged:
      return;
    case client::StepOutcome::Planned:
      fmt::print("step {}: would write: {}{}\n", c.step, change_text(c), regs);
      return;
    case client::StepOutcome::Written:
      fmt::print("step {}: written: {}{}{}\n", c.step, change_text(c), regs,
                 r.lost_replies == 0 ? ""
                                     : fmt::format(" ({} lost, settled by reading the step back)",
                                                   count_text(r.lost_replies, "reply", "replies")));
      return;
    case client::StepOutcome::Failed:
      fmt::print("step {}: FAILED: {}\n", c.step, r.error);
      return;
    case client::StepOutcome::NotAttempted:
      return;  // listed together at the end
  }
}

void print_report_tail(const client::RestoreReport& r) {
  if (!r.ok()) {
    fmt::print("written before the failure: {}\n",
               client::format_step_list(r.steps_with(client::StepOutcome::Written)));
    fmt::print("not attempted: {}\n",
               client::format_step_list(r.steps_with(client::StepOutcome::NotAttempted)));
  }
  fmt::print("unchanged: {}\n",
             client::format_step_list(r.steps_with(client::StepOutcome::Unchanged)));
  fmt::print("{}\n", r.summary());
  if (!r.ok()) {
    fmt::print(
        "the controller is partly restored: run the same restore again to finish (it writes only "
        "what still "
        "differs)\n");
  }
}

void print_step(unsigned n, const StepData& d) {
  if (d.is_blank()) {
    fmt::print("step {}: blank (not registered)\n", n);
    return;
  }
  fmt::print("step {}:\n", n);
  std::size_t w = 0;
  for (const auto& i : lec::step_fields()) w = std::max(w, i.name.size());
  for (const auto& i : lec::step_fields()) {
    fmt::print("  {}  {}{}{}\n", pad_right(i.name, w), field_text(d, i.field),
               i.unit.empty() ? "" : " ", i.unit);
  }
  for (const auto& m : lec::validation_messages(d, n)) fmt::print("  warning: {}\n", m);
}

// Numbers right-aligned, the mode left-aligned.
void print_step_table(const client::StepRecords& steps, const std::vector<unsigned>& shown) {
  // Columns: step, then every field; a second header line with the units.
  std::vector<std::vector<std::string>> rows;
  std::vector<std::string> names{"step"}, units{""};
  for (const auto& i : lec::step_fields()) {
    names.emplace_back(i.name);
    units.emplace_back(i.unit);
  }
  rows.push_back(names);
  rows.push_back(units);
  for (unsigned n : shown) {
    std::vector<std::string> row{fmt::format("{}", n)};
    for (const auto& i : lec::step_fields()) row.push_back(field_text(steps[n], i.field));
    rows.push_back(std::move(row));
  }
  std::vector<std::size_t> width(names.size(), 0);
  for (const auto& row : rows) {
    for (std::size_t k = 0; k < row.size(); ++k)
      width[k] = std::max(width[k], display_width(row[k]));
  }
  for (const auto& row : rows) {
    std::string line;
    for (std::size_t k = 0; k < row.size(); ++k) {
      if (k) line += "  ";
      const bool left = k == 1;  // mode
      line += left ? pad_right(row[k], width[k]) : pad_left(row[k], width[k]);
    }
    fmt::print("{}\n", rtrim(line));
  }
}

}  // namespace lec6::cli
