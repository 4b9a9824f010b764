#include "lec6/cycle/engine.hpp"

#include <fmt/format.h>

#include "lec6/lec/units.hpp"

namespace lec6::cycle {

namespace {

std::optional<std::string> axis_ready(const std::string& name, const AxisState& a) {
  if (!a.answered) return fmt::format("axis {} does not answer", name);
  if (a.flags.alarm()) return fmt::format("axis {} has an alarm (ALARM = 1)", name);
  if (a.flags.estop()) return fmt::format("axis {} is in emergency stop (ESTOP = 1)", name);
  return std::nullopt;
}

std::optional<std::string> may_move(const Cycle& c, const Step& s, const AxisStates& axes) {
  const AxisState& a = axes.at(s.axis);
  if (!a.flags.svre()) return fmt::format("axis {} is not servo ready (SVRE = 0)", s.axis);
  if (!a.flags.seton()) return fmt::format("axis {} is not homed (SETON = 0)", s.axis);
  const Axis& axis = *c.axis(s.axis);
  if (axis.soft_limits && s.kind != Step::Kind::RunStep) {
    const int32_t target =
        s.move.relative ? a.state.target_001mm + *s.move.position_001mm : *s.move.position_001mm;
    if (auto why = client::soft_limit_violation(*axis.soft_limits, target)) {
      return fmt::format("axis {}: {}", s.axis, *why);
    }
  }
  return user_interlock_violation(c, s.axis, axes);
}

}  // namespace

std::optional<std::string> user_interlock_violation(const Cycle& c, const std::string& moving,
                                                    const AxisStates& axes) {
  for (const auto& u : c.interlocks) {
    if (u.before_moving != moving) continue;
    auto it = axes.find(u.axis);
    if (it == axes.end()) return fmt::format("{} (axis {} was not read)", u.text, u.axis);
    const int32_t at = it->second.state.position_001mm;
    const bool holds = u.above_001mm ? at > *u.above_001mm : at < *u.below_001mm;
    if (!holds) return fmt::format("{} (axis {} is at {} mm)", u.text, u.axis, lec::format_mm(at));
  }
  return std::nullopt;
}

std::optional<std::string> interlock_violation(const Cycle& cycle, const Step& step,
                                               const AxisStates& axes) {
  for (const auto& axis : cycle.axes) {
    auto it = axes.find(axis.name);
    if (it == axes.end()) return fmt::format("axis {} was not read", axis.name);
    if (auto why = axis_ready(axis.name, it->second)) return why;
  }
  if (step.kind == Step::Kind::Parallel) {
    for (const auto& m : step.steps) {
      if (!m.moves()) continue;
      if (auto why = may_move(cycle, m, axes)) return why;
    }
    return std::nullopt;
  }
  if (step.moves()) return may_move(cycle, step, axes);
  return std::nullopt;
}

Target target_of(const Step& step, Outcome outcome) {
  if (auto it = step.on.find(outcome); it != step.on.end()) return it->second;
  switch (outcome) {
    case Outcome::Reached:
    case Outcome::Pushed:
    case Outcome::Done:
      return {Target::Continue, {}};
    default:
      return {Target::Abort, {}};
  }
}

Engine::Engine(const Cycle& cycle) : cycle_(cycle) {
  stack_.push_back({&cycle.steps, 0, cycle.repeat, cycle.repeat, "", nullptr, ""});
}

std::string Engine::path_of(const Frame& f) const {
  std::string p = fmt::format("{}{}", f.prefix, f.index + 1);
  if (f.times > 1) p += fmt::format(" ({}/{})", f.times - f.remaining + 1, f.times);
  return p;
}

const Step* Engine::walk(std::vector<Frame>& stack, unsigned& iteration, const AxisStates* axes,
                         std::optional<Finished>* failed, bool* until) const {
  while (!stack.empty()) {
    Frame& f = stack.back();
    if (f.index >= f.steps->size()) {
      // A repeat until: its condition, read after each pass.
      if (f.repeat && f.repeat->until) {
        if (!axes) {
          *until = true;
          return nullptr;
        }
        const auto a = axes->find(f.repeat->axis);
        const bool met = a != axes->end() && a->second.answered &&
                         f.repeat->condition_met(a->second.flags, a->second.state.position_001mm);
        if (met)
          f.remaining = 1;  // done: popped below
        else if (f.remaining == 1) {
          *failed = Finished{false, fmt::format("step {} ({}): not met after {} passes", f.path,
                                                f.repeat->text, f.times)};
          return nullptr;
        }
      }
      if (--f.remaining > 0) {
        f.index = 0;
        if (stack.size() == 1) ++iteration;
        continue;
      }
      stack.pop_back();
      if (!stack.empty()) ++stack.back().index;  // the repeat (or the step that branched) is done
      continue;
    }
    const Step& s = (*f.steps)[f.index];
    if (s.kind == Step::Kind::Repeat) {
      stack.push_back({&s.steps, 0, s.times, s.times, fmt::format("{}{}.", f.prefix, f.index + 1),
                       &s, path_of(f)});
      continue;
    }
    return &s;
  }
  return nullptr;
}

std::variant<Batch, Finished> Engine::next(const AxisStates& axes) {
  if (finished_) return *finished_;
  const Step* s = walk(stack_, iteration_, &axes, &finished_, nullptr);
  if (finished_) return *finished_;
  if (!s) {
    finished_ = Finished{true, "completed"};
    return *finished_;
  }
  Batch b{path_of(stack_.back()), s, {}};
  if (s->kind == Step::Kind::Parallel) {
    for (const auto& m : s->steps) b.activities.push_back({&m});
  } else {
    b.activities.push_back({s});
  }
  if (auto why = interlock_violation(cycle_, *s, axes)) {
    finished_ = Finished{
        false, fmt::format("refused before step {} ({}): interlock: {}", b.path, s->text, *why)};
    return *finished_;
  }
  current_ = b;
  return b;
}

Engine::AxesNeeded Engine::next_needs() const {
  if (finished_) return AxesNeeded::Nothing;
  std::vector<Frame> stack = stack_;
  unsigned iteration = iteration_;
  bool until = false;
  const Step* s = walk(stack, iteration, nullptr, nullptr, &until);
  if (until) return AxesNeeded::FlagsAndState;
  if (!s) return AxesNeeded::Nothing;
  return s->kind == Step::Kind::Dwell ? AxesNeeded::Flags : AxesNeeded::FlagsAndState;
}

std::string Engine::finished(const std::vector<ActivityResult>& results) {
  if (!current_ || results.size() != current_->activities.size()) {
    throw InvalidArgument("Engine::finished: one result per activity of the current batch");
  }
  const Batch b = *current_;
  current_.reset();
  std::optional<Target> branch;
  for (std::size_t i = 0; i < results.size(); ++i) {
    const Step& s = *b.activities[i].step;
    const Target t = target_of(s, results[i].outcome);
    if (t.kind == Target::Abort) {
      finished_ =
          Finished{false, fmt::format("aborted at step {} ({}): {}{}", b.path, s.text,
                                      outcome_name(results[i].outcome),
                                      results[i].detail.empty() ? "" : ": " + results[i].detail)};
      return "abort";
    }
    if (t.kind == Target::Branch && !branch) branch = t;
  }
  if (branch) {
    stack_.push_back(
        {&cycle_.branches.at(branch->branch), 0, 1, 1, branch->branch + ".", nullptr, ""});
    return "branch " + branch->branch;
  }
  ++stack_.back().index;
  return "continue";
}

void Engine::end(std::string reason) {
  current_.reset();
  if (!finished_) finished_ = Finished{false, std::move(reason)};
}

}  // namespace lec6::cycle
