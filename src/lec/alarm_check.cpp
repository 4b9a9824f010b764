// ALARM cross-checked with the alarm code and motion (alarm_check.hpp).

#include "lec6/lec/alarm_check.hpp"

#include <algorithm>

#include <fmt/format.h>

namespace lec6::lec {

std::string_view to_string(AlarmPolarity p) noexcept {
  return p == AlarmPolarity::ActiveLow ? "active-low" : "active-high";
}

std::optional<AlarmPolarity> parse_alarm_polarity(std::string_view text) noexcept {
  if (text == "active-high") return AlarmPolarity::ActiveHigh;
  if (text == "active-low") return AlarmPolarity::ActiveLow;
  return std::nullopt;
}

StatusFlags normalise_alarm(StatusFlags wire, AlarmPolarity p) noexcept {
  if (p == AlarmPolarity::ActiveLow) wire.set(StatusFlags::Alarm, !wire.alarm());
  return wire;
}

AlarmJudgement judge_alarm(const StatusFlags& flags, const AlarmGroup& group0,
                           AlarmPolarity configured) {
  AlarmJudgement j;
  const auto codes = group0.present();
  const AlarmPolarity other = configured == AlarmPolarity::ActiveHigh ? AlarmPolarity::ActiveLow
                                                                      : AlarmPolarity::ActiveHigh;
  const std::string wire_bit =
      fmt::format("X4F = {}", (flags.alarm() != (configured == AlarmPolarity::ActiveLow)) ? 1 : 0);
  if (!flags.alarm()) return j;  // no alarm by X4F; a code in group 0 is history
  if (codes.empty()) {
    // X4F says alarm, yet the controller reports no alarm code at all.
    j.suggested = other;
    j.disagreement = fmt::format(
        "{} reads as an alarm ({}), but the alarm history (D0380, group 0) holds no alarm code: "
        "this controller reports ALARM {}; set `alarm_polarity: {}`",
        wire_bit, to_string(configured),
        other == AlarmPolarity::ActiveLow ? "inverted" : "as the manual says (X4F = 1: alarm)",
        to_string(other));
    return j;
  }
  if (flags.busy()) {
    // An alarm stops the operation (BUSY 0); BUSY with X4F = alarm contradicts
    // it. Still reported as an alarm (its codes): a stop is the safe reading.
    j.suggested = other;
    j.disagreement = fmt::format(
        "{} reads as an alarm ({}) while BUSY = 1, but an alarm stops the operation; the code in "
        "group 0 ({}) may be an old one: this controller may report ALARM inverted; check "
        "`alarm_polarity: {}`",
        wire_bit, to_string(configured), codes.front(), to_string(other));
  }
  j.active = true;
  j.codes = codes;
  return j;
}

std::string alarm_after_reset(const std::vector<uint8_t>& left, AlarmPolarity configured) {
  std::string codes;
  for (uint8_t c : left)
    codes += fmt::format("{}{} ({})", codes.empty() ? "" : ", ", c, alarm_meaning(c));
  const AlarmPolarity other = configured == AlarmPolarity::ActiveHigh ? AlarmPolarity::ActiveLow
                                                                      : AlarmPolarity::ActiveHigh;
  const std::string_view reports =
      other == AlarmPolarity::ActiveLow ? "inverted" : "as the manual says (X4F = 1: alarm)";
  std::string out = "alarm still active after RESET: " + codes;
  const bool resettable = std::all_of(left.begin(), left.end(), alarm_resettable);
  if (!resettable) {
    // The remedy alarm_clear_hint gives everywhere; an old code of a healthy
    // controller of the other polarity survives the power cycle too.
    return out + fmt::format(
                     "; {}. If ALARM is still on after that while the axis is otherwise ready "
                     "(SVRE and SETON on), the code is an old one the alarm history keeps and "
                     "this controller reports ALARM {}: set `alarm_polarity: {}`",
                     alarm_clear_hint(left), reports, to_string(other));
  }
  return out + fmt::format(
                   "; RESET clears {}, so either its cause is still there (check the axis and "
                   "the step data), or this controller reports ALARM {} and is healthy: the "
                   "code is then an old one the alarm history keeps; if the axis is otherwise "
                   "ready (SVRE and SETON on), set `alarm_polarity: {}`",
                   left.size() == 1 ? "this code" : "these codes", reports, to_string(other));
}

}  // namespace lec6::lec
