// The faults a cycle file asks the twin to act out (`faults:`, --fault):
// which axis, which step, which of its runs, and that the step can be hit
// that way (a push_miss needs a push of that axis; a pass the step reaches).

#include <fmt/format.h>

#include <charconv>

#include "lec6/cycle/cycle_file.hpp"
#include "reader.hpp"

namespace lec6::cycle {

using detail::Reader;

namespace {

std::vector<std::string> split(std::string_view path) {
  std::vector<std::string> out;
  std::size_t from = 0;
  for (;;) {
    const auto dot = path.find('.', from);
    out.emplace_back(path.substr(from, dot == std::string_view::npos ? path.npos : dot - from));
    if (dot == std::string_view::npos) return out;
    from = dot + 1;
  }
}

std::optional<std::size_t> index_of(const std::string& token, std::size_t size) {
  std::size_t n = 0;
  const auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), n);
  if (ec != std::errc() || end != token.data() + token.size() || n == 0 || n > size) return {};
  return n - 1;
}

// How many times the step at a top-level path runs in one `lec cycle run`:
// the file's repeat times each enclosing repeat's. nullopt for a branch's
// step (a branch runs as often as it is taken).
std::optional<unsigned long long> runs_of(const Cycle& c, std::string_view path) {
  const auto tokens = split(path);
  const std::vector<Step>* list = &c.steps;
  unsigned long long runs = c.repeat;
  for (std::size_t i = 0; i < tokens.size(); ++i) {
    const auto at = index_of(tokens[i], list->size());
    if (!at) return std::nullopt;
    const Step& s = (*list)[*at];
    if (i + 1 < tokens.size()) {
      runs *= s.times;
      list = &s.steps;
    }
  }
  return runs;
}

bool pushes(const Step& s, const std::string& axis) {
  if (s.kind == Step::Kind::Push) return s.axis == axis;
  if (s.kind == Step::Kind::Parallel) {
    for (const auto& m : s.steps) {
      if (pushes(m, axis)) return true;
    }
  }
  return false;
}

std::string nth(unsigned n) {
  if (n == 1) return "";
  const char* suffix = (n % 100 >= 11 && n % 100 <= 13) ? "th"
                       : n % 10 == 1                    ? "st"
                       : n % 10 == 2                    ? "nd"
                       : n % 10 == 3                    ? "rd"
                                                        : "th";
  return fmt::format(" (its {}{} run)", n, suffix);
}

}  // namespace

const Step* find_step(const Cycle& c, std::string_view path) {
  const auto tokens = split(path);
  if (tokens.empty() || tokens[0].empty()) return nullptr;
  const std::vector<Step>* list = &c.steps;
  std::size_t i = 0;
  if (auto b = c.branches.find(tokens[0]); b != c.branches.end()) {
    list = &b->second;
    i = 1;
    if (tokens.size() == 1) return nullptr;
  }
  const Step* step = nullptr;
  for (; i < tokens.size(); ++i) {
    const auto at = index_of(tokens[i], list->size());
    if (!at) return nullptr;
    step = &(*list)[*at];
    if (i + 1 < tokens.size()) {
      if (step->kind != Step::Kind::Repeat) return nullptr;
      list = &step->steps;
    }
  }
  return step;
}

namespace detail {

Fault read_fault(const Reader& r, const YAML::Node& n, const std::string& f, const Cycle& c) {
  if (!n.IsMap()) {
    r.fail(n, f, "a fault is a map, e.g. {step: 6, push_miss: z} (docs/cycles.md)");
  }
  r.keys(n, f, {"step", "pass", "push_miss", "alarm", "cut_off", "code"});
  Fault out;
  out.mark = Reader::mark(n);
  int kinds = 0;
  for (const auto& [key, kind] :
       {std::pair{"push_miss", Fault::Kind::PushMiss}, std::pair{"alarm", Fault::Kind::Alarm},
        std::pair{"cut_off", Fault::Kind::CutOff}}) {
    if (!n[key]) continue;
    ++kinds;
    out.kind = kind;
    out.axis = r.text(n[key], f + "." + key);
    if (!c.axis(out.axis)) {
      std::vector<std::string> names;
      for (const auto& a : c.axes) names.push_back(a.name);
      r.fail(n[key], f + "." + key, Reader::unknown("axis", out.axis, names, "axes"));
    }
  }
  if (kinds != 1) {
    r.fail(n, f, "give exactly one of push_miss: AXIS, alarm: AXIS or cut_off: AXIS");
  }
  if (!n["step"]) r.fail(n, f + ".step", "a fault names the step it strikes at, e.g. step: 6");
  out.step = r.text(n["step"], f + ".step");
  const Step* step = find_step(c, out.step);
  if (!step) {
    r.fail(n["step"], f + ".step",
           fmt::format("no step '{}' in this cycle (steps 1-{}{}; a step in a repeat or a "
                       "branch is 4.2 or no_part.1)",
                       out.step, c.steps.size(), c.branches.empty() ? "" : ", branches"));
  }
  if (step->kind == Step::Kind::Repeat) {
    r.fail(n["step"], f + ".step",
           fmt::format("step {} is a repeat: name one of its steps ({}.1 to {}.{})", out.step,
                       out.step, out.step, step->steps.size()));
  }
  if (out.kind != Fault::Kind::PushMiss && step->kind == Step::Kind::RunStep) {
    r.fail(n["step"], f + ".step",
           fmt::format("step {} runs a stored step, which runs to its end before an alarm or a "
                       "cut_off could strike: give the fault to a move, push, wait or group",
                       out.step));
  }
  if (out.kind == Fault::Kind::PushMiss && !pushes(*step, out.axis)) {
    r.fail(n["push_miss"], f + ".push_miss",
           fmt::format("step {} ({}) has no push of {}: a push_miss needs one", out.step,
                       step->text, out.axis));
  }
  if (n["pass"]) {
    out.pass = static_cast<unsigned>(r.integer(n["pass"], f + ".pass", 1, 1000000));
    if (const auto runs = runs_of(c, out.step); runs && out.pass > *runs) {
      r.fail(n["pass"], f + ".pass",
             fmt::format("step {} runs {} time{} in a run of this cycle: pass {} never comes",
                         out.step, *runs, *runs == 1 ? "" : "s", out.pass));
    }
  }
  if (n["code"]) {
    if (out.kind != Fault::Kind::Alarm) r.fail(n["code"], f + ".code", "only an alarm has a code");
    out.alarm_code = static_cast<uint8_t>(r.integer(n["code"], f + ".code", 1, 255));
  }
  switch (out.kind) {
    case Fault::Kind::PushMiss:
      out.text = fmt::format("{}'s push at step {} finds no workpiece{}", out.axis, out.step,
                             nth(out.pass));
      break;
    case Fault::Kind::Alarm:
      out.text = fmt::format("alarm {} on {} at step {}{}", out.alarm_code, out.axis, out.step,
                             nth(out.pass));
      break;
    case Fault::Kind::CutOff:
      out.text = fmt::format("{} cut off the line at step {}{}", out.axis, out.step, nth(out.pass));
      break;
  }
  return out;
}

}  // namespace detail

Fault parse_fault(std::string_view yaml_text, const std::string& source, const Cycle& c) {
  const Reader r(source);
  YAML::Node node;
  try {
    node = YAML::Load(std::string(yaml_text));
  } catch (const YAML::ParserException& e) {
    throw CycleError(source, {}, "", "not valid YAML: " + e.msg);
  }
  return detail::read_fault(r, node, "fault", c);
}

}  // namespace lec6::cycle
