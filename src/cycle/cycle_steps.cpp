// The cycle file's steps: move, push, run_step, wait, dwell, parallel,
// repeat, and the conditions on their outcomes.

#include <fmt/format.h>

#include <algorithm>
#include <array>

#include "lec6/lec/units.hpp"
#include "reader.hpp"

namespace lec6::cycle {

namespace {
constexpr std::array<std::pair<Outcome, std::string_view>, 9> kOutcomes{{
    {Outcome::Reached, "reached"},
    {Outcome::Pushed, "pushed"},
    {Outcome::PushMissed, "push_missed"},
    {Outcome::Alarm, "alarm"},
    {Outcome::Timeout, "timeout"},
    {Outcome::Stopped, "stopped"},
    {Outcome::NotStarted, "not_started"},
    {Outcome::Refused, "refused"},
    {Outcome::Done, "done"},
}};
}  // namespace

std::string_view outcome_name(Outcome o) noexcept {
  if (o == Outcome::LineFault) return "line_fault";
  for (const auto& [k, n] : kOutcomes) {
    if (k == o) return n;
  }
  return "?";
}

std::optional<Outcome> outcome_from_name(std::string_view name) noexcept {
  for (const auto& [k, n] : kOutcomes) {
    if (n == name) return k;
  }
  return std::nullopt;
}

namespace detail {
namespace {

using lec::StepField;

const Duration kDefaultMotionTimeout = std::chrono::seconds(60);  // as `lec move`

struct Context {
  const Reader& r;
  const Cycle& cycle;
  const std::vector<std::string>& branches;
};

std::vector<std::string> axis_names(const Cycle& c) {
  std::vector<std::string> names;
  for (const auto& a : c.axes) names.push_back(a.name);
  return names;
}

const Axis& read_axis_name(const Context& x, const YAML::Node& n, const std::string& f) {
  if (!n["axis"]) x.r.fail(n, f + ".axis", "this step needs an axis");
  const std::string name = x.r.text(n["axis"], f + ".axis");
  const Axis* a = x.cycle.axis(name);
  if (!a)
    x.r.fail(n["axis"], f + ".axis", Reader::unknown("axis", name, axis_names(x.cycle), "axes"));
  return *a;
}

Target read_target(const Context& x, const YAML::Node& n, const std::string& f) {
  const std::string t = x.r.text(n, f);
  if (t == "abort") return {Target::Abort, {}};
  if (t == "continue") return {Target::Continue, {}};
  if (std::find(x.branches.begin(), x.branches.end(), t) == x.branches.end()) {
    std::vector<std::string> known = x.branches;
    known.insert(known.begin(), {"abort", "continue"});
    x.r.fail(n, f, Reader::unknown("branch", t, known, "known"));
  }
  return {Target::Branch, t};
}

void read_conditions(const Context& x, const YAML::Node& n, const std::string& f, Step& s) {
  if (const auto& miss = n["on_miss"])
    s.on[Outcome::PushMissed] = read_target(x, miss, f + ".on_miss");
  const auto& on = n["on"];
  if (!on) return;
  if (!on.IsMap()) x.r.fail(on, f + ".on", "expected a map OUTCOME: abort | continue | BRANCH");
  for (const auto& kv : on) {
    const std::string key = kv.first.as<std::string>();
    const auto o = outcome_from_name(key);
    if (!o) {
      std::vector<std::string> known;
      for (const auto& [k, name] : kOutcomes) known.emplace_back(name);
      x.r.fail(kv.first, f + ".on." + key, Reader::unknown("outcome", key, known, "outcomes"));
    }
    s.on[*o] = read_target(x, kv.second, f + ".on." + key);
  }
}

// `to`: a point of the axis or a number of mm.
int32_t read_to(const Context& x, const YAML::Node& n, const std::string& f, const Axis& a,
                std::string& point) {
  const std::string t = x.r.text(n, f);
  if (auto it = a.points_001mm.find(t); it != a.points_001mm.end()) {
    point = t;
    return it->second;
  }
  if (lec::parse_mm(t)) return static_cast<int32_t>(x.r.step_field(n, f, StepField::Position));
  std::vector<std::string> known;
  for (const auto& [name, v] : a.points_001mm) known.push_back(name);
  x.r.fail(n, f, Reader::unknown(fmt::format("point of axis {}", a.name), t, known, "points"));
}

void check_direct(const Context& x, const YAML::Node& n, const std::string& f, const Step& s,
                  const Axis& a) {
  const lec::StepData data = client::merge_direct({}, s.move);
  const auto issues = lec::validate(data);
  if (!issues.empty()) x.r.fail(n, f, issues.front().message);
  if (!s.move.relative && a.soft_limits) {
    if (auto why = client::soft_limit_violation(*a.soft_limits, *s.move.position_001mm)) {
      x.r.fail(n["to"], f + ".to",
               fmt::format("{} mm is outside axis {}'s soft limits {} to {} mm",
                           lec::format_mm(*s.move.position_001mm), a.name,
                           lec::format_mm(a.soft_limits->min_001mm),
                           lec::format_mm(a.soft_limits->max_001mm)));
    }
  }
}

void read_motion(const Context& x, const YAML::Node& n, const std::string& f, Step& s, bool push) {
  const Reader& r = x.r;
  if (push) {
    r.keys(n, f,
           {"axis", "to", "force", "trigger", "push_speed", "distance", "speed", "accel", "decel",
            "moving_force", "timeout", "on_miss", "on"});
  } else {
    r.keys(n, f,
           {"axis", "to", "relative", "speed", "accel", "decel", "moving_force", "in_position",
            "area", "timeout", "on"});
  }
  const Axis& a = read_axis_name(x, n, f);
  s.axis = a.name;
  if (!n["to"]) r.fail(n, f + ".to", "a move needs a target: to: POINT or MM");
  if (n["relative"]) s.move.relative = r.boolean(n["relative"], f + ".relative");
  s.move.position_001mm = read_to(x, n["to"], f + ".to", a, s.point);
  auto u16 = [&](const char* key, StepField field, std::optional<uint16_t>& out) {
    if (n[key]) out = static_cast<uint16_t>(r.step_field(n[key], f + "." + key, field));
  };
  auto i32 = [&](const char* key, StepField field, std::optional<int32_t>& out) {
    if (n[key]) out = static_cast<int32_t>(r.step_field(n[key], f + "." + key, field));
  };
  u16("speed", StepField::Speed, s.move.speed_mm_s);
  u16("accel", StepField::Acceleration, s.move.acceleration_mm_s2);
  u16("decel", StepField::Deceleration, s.move.deceleration_mm_s2);
  u16("moving_force", StepField::MovingForce, s.move.moving_force_pct);
  i32("in_position", StepField::InPosition, s.move.in_position_001mm);
  i32("distance", StepField::InPosition, s.move.in_position_001mm);
  if (const auto& area = n["area"]) {
    if (!area.IsSequence() || area.size() != 2) r.fail(area, f + ".area", "expected [A, B] in mm");
    s.move.area1_001mm =
        static_cast<int32_t>(r.step_field(area[0], f + ".area[0]", StepField::Area1));
    s.move.area2_001mm =
        static_cast<int32_t>(r.step_field(area[1], f + ".area[1]", StepField::Area2));
  }
  if (push) {
    if (!n["force"]) r.fail(n, f + ".force", "a push needs its pushing force, % (1-100)");
    u16("force", StepField::PushingForce, s.move.pushing_force_pct);
    if (*s.move.pushing_force_pct == 0)
      r.fail(n["force"], f + ".force", "a push needs a force above 0 %");
    u16("trigger", StepField::TriggerLevel, s.move.trigger_level_pct);
    u16("push_speed", StepField::PushingSpeed, s.move.pushing_speed_mm_s);
  }
  s.timeout = n["timeout"] ? r.duration(n["timeout"], f + ".timeout") : kDefaultMotionTimeout;
  check_direct(x, n, f, s, a);
  const std::string target =
      s.point.empty() ? lec::format_mm(*s.move.position_001mm) + " mm"
                      : fmt::format("{} ({} mm)", s.point, lec::format_mm(*s.move.position_001mm));
  s.text = fmt::format("{} {} {} {}", push ? "push" : "move", a.name, s.move.relative ? "by" : "to",
                       target);
}

// An axis's condition, a wait's or a repeat's `until`: exactly one of flag
// (with value), above_mm or below_mm. Returns it in words ("z INP = 1").
std::string read_condition(const Context& x, const YAML::Node& n, const std::string& f, Step& s,
                           const char* what) {
  const Reader& r = x.r;
  const Axis& a = read_axis_name(x, n, f);
  s.axis = a.name;
  const int given = (n["flag"] ? 1 : 0) + (n["above_mm"] ? 1 : 0) + (n["below_mm"] ? 1 : 0);
  if (given != 1)
    r.fail(n, f,
           fmt::format("a {} needs exactly one of flag, above_mm or below_mm{}", what,
                       std::string_view(what) == "wait" ? " (a pause is a dwell)" : ""));
  if (n["flag"]) {
    const std::string name = r.text(n["flag"], f + ".flag");
    std::vector<std::string> known;
    for (unsigned b = 8; b < 16; ++b) {
      known.emplace_back(lec::status_flag_name(b));
      if (name == known.back()) s.flag = static_cast<lec::StatusFlags::Bit>(b);
    }
    if (!s.flag)
      r.fail(n["flag"], f + ".flag", Reader::unknown("status flag", name, known, "flags"));
    if (n["value"]) s.flag_value = r.boolean(n["value"], f + ".value");
    return fmt::format("{} {} = {}", a.name, name, s.flag_value ? 1 : 0);
  }
  const bool above = static_cast<bool>(n["above_mm"]);
  const char* key = above ? "above_mm" : "below_mm";
  const int32_t v = r.mm(n[key], f + "." + key);
  (above ? s.above_001mm : s.below_001mm) = v;
  if (a.soft_limits && (above ? v >= a.soft_limits->max_001mm : v <= a.soft_limits->min_001mm)) {
    r.fail(n[key], f + "." + key,
           fmt::format("axis {} can never be {} {} mm within its soft limits {} to {} mm: the {} "
                       "would never end",
                       a.name, above ? "above" : "below", lec::format_mm(v),
                       lec::format_mm(a.soft_limits->min_001mm),
                       lec::format_mm(a.soft_limits->max_001mm), what));
  }
  return fmt::format("{} {} {} mm", a.name, above ? "above" : "below", lec::format_mm(v));
}

void read_wait(const Context& x, const YAML::Node& n, const std::string& f, Step& s) {
  const Reader& r = x.r;
  r.keys(n, f, {"axis", "flag", "value", "above_mm", "below_mm", "timeout", "on"});
  const std::string condition = read_condition(x, n, f, s, "wait");
  if (!n["timeout"])
    r.fail(n, f + ".timeout", "a wait needs a timeout: a wait that may never end is refused");
  s.timeout = r.duration(n["timeout"], f + ".timeout");
  s.text = "wait for " + condition;
}

Step read_step(const Context& x, const YAML::Node& n, const std::string& f);

void read_parallel(const Context& x, const YAML::Node& n, const std::string& f, Step& s) {
  if (!n.IsSequence() || n.size() == 0) x.r.fail(n, f, "a parallel group is a list of steps");
  std::map<std::string, std::size_t> moved;  // axis → the member that moves it
  std::string names;
  for (std::size_t i = 0; i < n.size(); ++i) {
    const std::string mf = fmt::format("{}[{}]", f, i);
    Step m = read_step(x, n[i], mf);
    if (m.kind == Step::Kind::Parallel || m.kind == Step::Kind::Repeat) {
      x.r.fail(n[i], mf,
               "a parallel group holds moves, pushes, waits and dwells, not groups or repeats");
    }
    if (m.kind == Step::Kind::RunStep) {
      x.r.fail(
          n[i], mf,
          "run_step is not supported inside a parallel group yet: run it as a step of its own");
    }
    if (m.moves()) {
      if (auto it = moved.find(m.axis); it != moved.end()) {
        x.r.fail(n[i], mf,
                 fmt::format("axis {} is moved twice in this parallel group (also by {}[{}])",
                             m.axis, f, it->second));
      }
      moved[m.axis] = i;
    }
    names += (names.empty() ? "" : " | ") + m.text;
    s.steps.push_back(std::move(m));
  }
  s.text = "parallel: " + names;
}

Step read_step(const Context& x, const YAML::Node& n, const std::string& f) {
  const Reader& r = x.r;
  if (!n.IsMap() || n.size() == 0)
    r.fail(n, f,
           "a step is a map with one kind: move, push, run_step, wait, dwell, parallel or repeat");
  r.keys(n, f, {"move", "push", "run_step", "wait", "dwell", "parallel", "repeat"});
  if (n.size() != 1)
    r.fail(n, f, "one kind per step (e.g. - move: {...}; a group is a parallel: [...])");
  const std::string kind = n.begin()->first.as<std::string>();
  const YAML::Node body = n.begin()->second;
  const std::string bf = f + "." + kind;
  Step s;
  s.mark = Reader::mark(n);
  if (kind == "move" || kind == "push") {
    s.kind = kind == "move" ? Step::Kind::Move : Step::Kind::Push;
    read_motion(x, body, bf, s, kind == "push");
    read_conditions(x, body, bf, s);
  } else if (kind == "run_step") {
    s.kind = Step::Kind::RunStep;
    r.keys(body, bf, {"axis", "step", "timeout", "on"});
    s.axis = read_axis_name(x, body, bf).name;
    if (!body["step"]) r.fail(body, bf + ".step", "run_step needs the step number (0-63)");
    s.stored_step = static_cast<unsigned>(r.integer(body["step"], bf + ".step", 0, 63));
    s.timeout =
        body["timeout"] ? r.duration(body["timeout"], bf + ".timeout") : kDefaultMotionTimeout;
    s.text = fmt::format("run step {} on {}", s.stored_step, s.axis);
    read_conditions(x, body, bf, s);
  } else if (kind == "wait") {
    s.kind = Step::Kind::Wait;
    read_wait(x, body, bf, s);
    read_conditions(x, body, bf, s);
  } else if (kind == "dwell") {
    s.kind = Step::Kind::Dwell;
    s.dwell = r.duration(body, bf);
    s.text = fmt::format("dwell {:.3f} s", to_seconds(s.dwell));
  } else if (kind == "parallel") {
    s.kind = Step::Kind::Parallel;
    read_parallel(x, body, bf, s);
  } else {
    s.kind = Step::Kind::Repeat;
    r.keys(body, bf, {"times", "until", "steps"});
    if (!body["times"])
      r.fail(body, bf + ".times",
             body["until"] ? "repeat until needs times: N, the most passes (a repeat that may "
                             "never end is refused)"
                           : "repeat needs times: N");
    s.times = static_cast<unsigned>(r.integer(body["times"], bf + ".times", 1, 1000000));
    if (!body["steps"]) r.fail(body, bf + ".steps", "repeat needs its steps");
    s.steps = read_steps(x.r, body["steps"], bf + ".steps", x.cycle, x.branches);
    s.text = fmt::format("repeat {} times", s.times);
    if (const auto& u = body["until"]) {
      r.keys(u, bf + ".until", {"axis", "flag", "value", "above_mm", "below_mm"});
      s.until = true;
      s.text = fmt::format("repeat until {}, at most {} times",
                           read_condition(x, u, bf + ".until", s, "repeat's until"), s.times);
    }
  }
  return s;
}

}  // namespace

std::vector<Step> read_steps(const Reader& r, const YAML::Node& list, const std::string& field,
                             const Cycle& cycle, const std::vector<std::string>& branch_names) {
  if (!list.IsSequence() || list.size() == 0) r.fail(list, field, "expected a list of steps");
  const Context x{r, cycle, branch_names};
  std::vector<Step> steps;
  for (std::size_t i = 0; i < list.size(); ++i) {
    steps.push_back(read_step(x, list[i], fmt::format("{}[{}]", field, i)));
  }
  return steps;
}

}  // namespace detail
}  // namespace lec6::cycle
