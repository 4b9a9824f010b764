// Moves: a stored step (DRIVE), a direct operation (D9102–D9111 + D9100), a
// follower's retarget, and the wait that ends each (completion.hpp).

#include <fmt/format.h>

#include <algorithm>

#include "client/coil_reset.hpp"
#include "client/wire_dated.hpp"
#include "lec6/client/actuator.hpp"
#include "lec6/lec/step_defaults.hpp"
#include "lec6/lec/units.hpp"

namespace lec6::client {
namespace {

using lec::Coil;

// The goal a record is judged against; INC targets count from D9004 before
// the start (the controller's "previous target", digest §6).
MoveGoal goal_of(const lec::StepData& d, int32_t target_before, std::optional<unsigned> step) {
  MoveGoal g;
  g.step = step;
  const bool relative = d.movement_mode == lec::MovementMode::Incremental;
  g.target_001mm =
      relative ? static_cast<int32_t>(int64_t{target_before} + d.position_001mm) : d.position_001mm;
  g.speed_mm_s = d.speed_mm_s;
  g.acceleration_mm_s2 = d.acceleration_mm_s2;
  g.deceleration_mm_s2 = d.deceleration_mm_s2;
  if (d.is_pushing()) {
    g.operation = Operation::Pushing;
    g.pushing_distance_001mm = d.in_position_001mm;  // a pushing step's "In position"
    g.trigger_level_pct = d.trigger_level_pct;
  } else {
    g.in_position_001mm = d.in_position_001mm;
  }
  return g;
}

// The contiguous register range [first, first + count) where `want` differs
// from `have`; count 0 when nothing does.
std::pair<unsigned, unsigned> changed_range(const lec::StepData& have, const lec::StepData& want) {
  const auto a = have.to_registers();
  const auto b = want.to_registers();
  unsigned first = lec::StepData::kRegisters, last = 0;
  for (unsigned i = 0; i < lec::StepData::kRegisters; ++i) {
    if (a[i] != b[i]) first = std::min(first, i), last = i;
  }
  if (first == lec::StepData::kRegisters) return {0, 0};
  return {first, last - first + 1};
}

}  // namespace

lec::StepData default_direct_data() {
  return lec::default_step_data();
}

namespace {

// keep: the controller's data, when they are valid (power-on: blank).
bool keeps(const lec::StepData& current, const DirectMove& m) {
  return m.keep && lec::validate(current).empty();
}

}  // namespace

lec::StepData merge_direct(const lec::StepData& current, const DirectMove& m) {
  lec::StepData d = keeps(current, m) ? current : default_direct_data();
  d.movement_mode = m.relative ? lec::MovementMode::Incremental : lec::MovementMode::Absolute;
  if (m.position_001mm) d.position_001mm = *m.position_001mm;
  if (m.speed_mm_s) d.speed_mm_s = *m.speed_mm_s;
  if (m.acceleration_mm_s2) d.acceleration_mm_s2 = *m.acceleration_mm_s2;
  if (m.deceleration_mm_s2) d.deceleration_mm_s2 = *m.deceleration_mm_s2;
  if (m.moving_force_pct) d.moving_force_pct = *m.moving_force_pct;
  if (m.in_position_001mm) d.in_position_001mm = *m.in_position_001mm;
  if (m.area1_001mm) d.area1_001mm = *m.area1_001mm;
  if (m.area2_001mm) d.area2_001mm = *m.area2_001mm;
  if (m.pushing_speed_mm_s) d.pushing_speed_mm_s = *m.pushing_speed_mm_s;
  // A move without a pushing force is a positioning move, whatever the
  // previous one was (also with keep).
  d.pushing_force_pct = m.pushing_force_pct.value_or(0);
  d.trigger_level_pct =
      m.trigger_level_pct.value_or(m.pushing_force_pct ? *m.pushing_force_pct : 0);
  return d;
}

std::vector<std::string> kept_direct_values(const lec::StepData& current, const DirectMove& m) {
  std::vector<std::string> kept;
  if (!keeps(current, m)) return kept;
  const auto& c = current;
  if (!m.speed_mm_s) kept.push_back(fmt::format("speed {} mm/s", c.speed_mm_s));
  if (!m.acceleration_mm_s2) kept.push_back(fmt::format("accel {} mm/s²", c.acceleration_mm_s2));
  if (!m.deceleration_mm_s2) kept.push_back(fmt::format("decel {} mm/s²", c.deceleration_mm_s2));
  if (!m.moving_force_pct) kept.push_back(fmt::format("moving force {} %", c.moving_force_pct));
  if (!m.in_position_001mm)
    kept.push_back(fmt::format("in position {} mm", lec::format_mm(c.in_position_001mm)));
  if (!m.area1_001mm && !m.area2_001mm && (c.area1_001mm != 0 || c.area2_001mm != 0)) {
    kept.push_back(
        fmt::format("area {}:{} mm", lec::format_mm(c.area1_001mm), lec::format_mm(c.area2_001mm)));
  }
  if (m.pushing_force_pct && !m.pushing_speed_mm_s)
    kept.push_back(fmt::format("pushing speed {} mm/s", c.pushing_speed_mm_s));
  return kept;
}

std::optional<std::string> soft_limit_violation(const SoftLimits& l, int32_t target_001mm) {
  if (target_001mm >= l.min_001mm && target_001mm <= l.max_001mm) return std::nullopt;
  return fmt::format(
      "target {} mm is beyond the soft limits {} to {} mm of this axis: nothing was "
      "written",
      lec::format_mm(target_001mm), lec::format_mm(l.min_001mm), lec::format_mm(l.max_001mm));
}

void Actuator::check_soft_limits(int32_t target_001mm) const {
  if (!soft_limits_) return;
  if (auto why = soft_limit_violation(*soft_limits_, target_001mm)) throw InvalidRequest(*why);
}

MoveResult Actuator::run_step(unsigned step, TimePoint deadline, const WaitOptions& wait) {
  const std::string what = fmt::format("step {}", step);
  const Before before = ready_to_move(what);
  const auto data = client_.read_step(step);
  if (data.is_blank()) {
    throw InvalidRequest(fmt::format(
        "step {} is blank (not registered): set it first with `lec step set {} ...`", step, step));
  }
  if (data.movement_mode == lec::MovementMode::Absolute && !before.flags.seton()) {
    throw InvalidRequest(fmt::format(
        "step {} is ABS and the axis is not homed (SETON = 0): run `lec home` first", step));
  }
  MoveGoal goal = goal_of(data, before.state.target_001mm, step);
  if (before.state.speed_mm_s == 0) goal.from_001mm = before.state.position_001mm;
  check_soft_limits(goal.target_001mm);
  // DRIVE starts on a rising edge: make sure it is low first.
  if (before.controls.test(Coil::DRIVE)) client_.write_coil(Coil::DRIVE, false);
  client_.select_step(step);
  detail::CoilReset clear_drive(client_, Coil::DRIVE);
  // Writing DRIVE = 1 again after a lost reply is harmless: it is a level,
  // and a repeat makes no new edge. So even INC steps cannot start twice.
  client_.write_coil(Coil::DRIVE, true);
  const StartedMove started{detail::wire_dated(
      MoveStart{goal, before.flags, before.state, false, client_.clock().now()}, client_)};
  return this->wait(started, deadline, wait);
}

StartedMove Actuator::start(const DirectMove& m) {
  return go(prepare(m));
}

PreparedMove Actuator::prepare(const DirectMove& m) {
  // The values first (the user's own error before the machine's state), then
  // the controller: nothing is written unless both are fine.
  const auto current = client_.read_direct();
  const lec::StepData want = merge_direct(current, m);
  const auto issues = lec::validation_messages(want, std::nullopt);
  if (!issues.empty()) throw InvalidRequest(issues.front());
  const Before before = ready_to_move("the move");
  const bool relative = want.movement_mode == lec::MovementMode::Incremental;
  if (!relative && !before.flags.seton()) {
    throw InvalidRequest(
        "an ABS move needs the axis homed (SETON = 0): run `lec home`, or move --relative");
  }

  MoveGoal goal = goal_of(want, before.state.target_001mm, std::nullopt);
  goal.kept = kept_direct_values(current, m);
  if (before.state.speed_mm_s == 0) goal.from_001mm = before.state.position_001mm;
  check_soft_limits(goal.target_001mm);

  // Only the registers that change are written (one contiguous range).
  if (const auto [first, count] = changed_range(current, want); count > 0)
    client_.write_direct_registers(want, first, count);
  direct_written_ = want;
  return PreparedMove{goal, before.flags, before.state, relative};
}

StartedMove Actuator::go(const PreparedMove& p) {
  const MoveGoal& goal = p.goal;
  if (p.relative) {
    // An INC start is never resent blindly: a repeat would move twice. After a
    // lost reply, the target position tells whether the controller started.
    try {
      client_.write_direct_start(Retry::Never);
    } catch (const TransportError& e) {
      if (e.kind() == TransportErrorKind::Port || e.kind() == TransportErrorKind::EchoMismatch)
        throw;
      const auto after = client_.read_state();
      if (after.target_001mm != goal.target_001mm) client_.write_direct_start(Retry::Never);
    }
  } else {
    client_.write_direct_start(Retry::Safe);
  }
  return StartedMove{detail::wire_dated(
      MoveStart{goal, p.flags_before, p.state_before, false, client_.clock().now()}, client_)};
}

MoveResult Actuator::move(const DirectMove& m, TimePoint deadline, const WaitOptions& wait) {
  return this->wait(start(m), deadline, wait);
}

StartedMove Actuator::retarget(int32_t position_001mm, std::optional<uint16_t> speed_mm_s) {
  if (!direct_written_) {
    DirectMove m;
    m.position_001mm = position_001mm;
    m.speed_mm_s = speed_mm_s;
    StartedMove s = start(m);
    s.start.may_be_running = true;
    return s;
  }
  check_soft_limits(position_001mm);
  lec::StepData want = *direct_written_;
  want.movement_mode = lec::MovementMode::Absolute;
  want.position_001mm = position_001mm;
  if (speed_mm_s) want.speed_mm_s = *speed_mm_s;
  if (const auto [first, count] = changed_range(*direct_written_, want); count > 0)
    client_.write_direct_registers(want, first, count);
  direct_written_ = want;
  client_.write_direct_start(Retry::Safe);  // ABS: a repeat changes nothing
  // No flags were read: the completion rule must assume a move is running.
  MoveStart s;
  s.goal = goal_of(want, 0, std::nullopt);
  s.flags_before.set(lec::StatusFlags::Busy, true);
  s.may_be_running = true;
  s.at = client_.clock().now();
  return StartedMove{s};
}

MoveResult Actuator::wait(const StartedMove& started, TimePoint deadline, const WaitOptions& w) {
  Completion done(started.start, deadline, w.completion);
  MoveResult r = poll_until_done(done, started.start.at, w);
  const char* what = started.start.goal.operation == Operation::Home ? "return to origin"
                     : started.start.goal.step                       ? "the step"
                                                                     : "the move";
  return conclude(std::move(r), what);
}

}  // namespace lec6::client
