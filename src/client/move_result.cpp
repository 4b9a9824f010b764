#include "lec6/client/move_result.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "lec6/lec/alarms.hpp"
#include "lec6/lec/units.hpp"

namespace lec6::client {
namespace {

std::string mm(int64_t v) {
  return lec::format_mm(v) + " mm";
}

std::string cause_text(StopCause c) {
  switch (c) {
    case StopCause::Interrupted:
      return "interrupted: decelerating stop sent by this client";
    case StopCause::ServoOff:
      return "servo off: SVRE = 0";
    case StopCause::EmergencyStop:
      return "emergency stop: ESTOP = 1";
    case StopCause::Released:
      return "jog released";
    case StopCause::Unknown:
      break;
  }
  return "BUSY fell without INP and without an alarm: HOLD / stop (RESET) / servo off, here or "
         "from another master";
}

std::string stopped_text(const MoveResult& r) {
  const std::string where = mm(r.state.position_001mm);
  switch (r.goal.operation) {
    case Operation::Jog:
      return fmt::format("stopped at {} ({})", where, cause_text(r.stop_cause));
    case Operation::Home:
      return fmt::format("stopped at {} before reaching the origin ({}{})", where,
                         cause_text(r.stop_cause), r.flags.seton() ? "" : "; SETON = 0: not homed");
    case Operation::Pushing:
      return fmt::format("stopped at {} before the end of the push from {} ({})", where,
                         mm(r.goal.target_001mm), cause_text(r.stop_cause));
    case Operation::Positioning:
      break;
  }
  return fmt::format("stopped at {} before the target {} ({})", where, mm(r.goal.target_001mm),
                     cause_text(r.stop_cause));
}

std::string alarm_text(const MoveResult& r) {
  if (r.alarm_codes.empty()) {
    return fmt::format("alarm (X4F = 1, no code in the history) at {}", mm(r.state.position_001mm));
  }
  std::string codes;
  for (uint8_t c : r.alarm_codes) {
    codes += fmt::format("{}{}: {}", codes.empty() ? "" : "; ", c, lec::alarm_meaning(c));
  }
  return fmt::format("alarm {} (at {}); {}", codes, mm(r.state.position_001mm),
                     lec::alarm_clear_hint(r.alarm_codes));
}

}  // namespace

std::string_view outcome_name(MoveOutcome o) noexcept {
  switch (o) {
    case MoveOutcome::Reached:
      return "reached";
    case MoveOutcome::Pushed:
      return "pushed";
    case MoveOutcome::PushMissed:
      return "push_missed";
    case MoveOutcome::Stopped:
      return "stopped";
    case MoveOutcome::Alarm:
      return "alarm";
    case MoveOutcome::Deadline:
      return "deadline";
    case MoveOutcome::NotStarted:
      return "not_started";
  }
  return "?";
}

std::string MoveResult::describe() const {
  std::string line = outcome_text();
  if (!goal.kept.empty())
    line += fmt::format("; kept from the controller: {}", fmt::join(goal.kept, ", "));
  return line;
}

std::string MoveResult::outcome_text() const {
  const double s = to_seconds(elapsed);
  switch (outcome) {
    case MoveOutcome::Reached:
      if (goal.operation == Operation::Home) {
        return fmt::format("reached the origin: {} (SETON, INP = {}) in {:.2f} s",
                           mm(state.position_001mm), in_position ? 1 : 0, s);
      }
      return fmt::format("reached {} (INP, within ±{}) in {:.2f} s", mm(state.position_001mm),
                         mm(goal.in_position_001mm), s);
    case MoveOutcome::Pushed:
      return fmt::format("pushed: workpiece at {}, thrust {} % (INP) in {:.2f} s",
                         mm(state.position_001mm), state.thrust_pct, s);
    case MoveOutcome::PushMissed:
      return fmt::format(
          "push missed: moved the whole pushing distance ({}) without contact (INP = 0), at {}",
          mm(goal.pushing_distance_001mm), mm(state.position_001mm));
    case MoveOutcome::Stopped:
      return stopped_text(*this);
    case MoveOutcome::Alarm:
      return alarm_text(*this);
    case MoveOutcome::Deadline:
      return fmt::format(
          "deadline: still running after {:.2f} s, at {} ({}); the axis may "
          "still be moving: `lec stop` stops it",
          s, mm(state.position_001mm), flags.describe());
    case MoveOutcome::NotStarted:
      return fmt::format(
          "the controller did not start the move: no BUSY within {:.2f} s of the start, and "
          "nothing else showed it (D9004 target {}, OUT0-OUT5 = {}, {}); a stop (RESET) was sent "
          "so that a late start cannot run unattended",
          s, mm(state.target_001mm), flags.out(), flags.describe());
  }
  return "?";
}

}  // namespace lec6::client
