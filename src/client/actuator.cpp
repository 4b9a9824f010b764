#include "lec6/client/actuator.hpp"

#include <fmt/format.h>

#include "lec6/lec/units.hpp"

namespace lec6::client {
namespace {

using lec::Coil;

std::string codes_text(const std::vector<uint8_t>& codes) {
  std::string out;
  for (uint8_t c : codes)
    out += fmt::format("{}{} ({})", out.empty() ? "" : ", ", c, lec::alarm_meaning(c));
  return out.empty() ? "no code in the history" : out;
}

// Clears a coil when leaving scope, whatever happened (SETUP after homing,
// DRIVE after a step: the manual asks for it and field drivers always do it).
class CoilReset {
 public:
  CoilReset(Client& c, Coil coil) : client_(c), coil_(coil) {}
  ~CoilReset() {
    try {
      client_.write_coil(coil_, false);
    } catch (...) {  // the primary error is already on its way
    }
  }
  CoilReset(const CoilReset&) = delete;
  CoilReset& operator=(const CoilReset&) = delete;

 private:
  Client& client_;
  Coil coil_;
};

}  // namespace

lec::StepData default_direct_data() {
  lec::StepData d;
  d.movement_mode = lec::MovementMode::Absolute;
  d.speed_mm_s = 100;
  d.acceleration_mm_s2 = 1000;
  d.deceleration_mm_s2 = 1000;
  d.pushing_force_pct = 0;
  d.trigger_level_pct = 0;
  d.pushing_speed_mm_s = 20;
  d.moving_force_pct = 100;
  d.in_position_001mm = 50;  // 0.50 mm
  return d;
}

lec::StepData merge_direct(const lec::StepData& current, const DirectMove& m) {
  lec::StepData d = lec::validate(current).empty() ? current : default_direct_data();
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
  // A move without --push is a positioning move, whatever the previous one was.
  d.pushing_force_pct = m.pushing_force_pct.value_or(0);
  d.trigger_level_pct =
      m.trigger_level_pct.value_or(m.pushing_force_pct ? *m.pushing_force_pct : 0);
  return d;
}

void Actuator::set_serial_mode(bool serial) {
  client_.write_coil(Coil::SerialMode, serial);
}

void Actuator::require_serial_mode(const lec::ControlFlags& controls) {
  if (!controls.serial_mode) {
    throw InvalidRequest(
        "the controller is in parallel input mode (Y30 = 0): operation commands are refused; run "
        "`lec serial on`");
  }
}

std::vector<uint8_t> Actuator::active_alarms(const lec::StatusFlags& flags) {
  if (!flags.alarm()) return {};
  return client_.read_alarms().groups[0].present();
}

void Actuator::raise_alarm(const lec::StatusFlags& flags, std::string_view during) {
  auto codes = active_alarms(flags);
  throw AlarmError(
      codes, fmt::format("the controller raised an alarm during {}: {}; clear it with `lec reset`",
                         during, codes_text(codes)));
}

void Actuator::check_cancel(const WaitOptions& wait) {
  if (wait.cancel && wait.cancel()) {
    stop();
    throw Cancelled("interrupted: the axis was stopped (decelerating stop)");
  }
}

void Actuator::check_deadline(TimePoint deadline, std::string_view what) {
  if (client_.clock().now() > deadline) {
    throw DeadlineError(fmt::format("{} did not finish before its deadline", what));
  }
}

void Actuator::pulse(Coil coil) {
  client_.write_coil(coil, true);
  client_.write_coil(coil, false);
}

void Actuator::servo_on(TimePoint deadline, const WaitOptions& wait) {
  require_serial_mode(client_.read_controls());
  client_.write_coil(Coil::SVON, true);
  const TimePoint start = client_.clock().now();
  for (;;) {
    const auto flags = client_.read_flags();
    if (wait.progress) wait.progress({lec::StateData{}, flags, client_.clock().now() - start});
    if (flags.svre()) return;
    if (flags.alarm()) raise_alarm(flags, "servo on");
    if (flags.estop())
      throw AlarmError({}, "servo cannot turn on: emergency stop (ESTOP) is active");
    check_cancel(wait);
    check_deadline(deadline, "servo on (waiting for SVRE)");
  }
}

void Actuator::servo_off(TimePoint deadline, const WaitOptions& wait) {
  client_.write_coil(Coil::SVON, false);
  for (;;) {
    const auto flags = client_.read_flags();
    if (!flags.svre()) return;
    check_cancel(wait);
    check_deadline(deadline, "servo off (waiting for SVRE to fall)");
  }
}

MoveResult Actuator::home(TimePoint deadline, const WaitOptions& wait) {
  require_serial_mode(client_.read_controls());
  const auto before = client_.read_flags();
  if (!before.svre())
    throw InvalidRequest("return to origin needs the servo on (SVRE = 0): run `lec servo on`");
  if (before.alarm()) raise_alarm(before, "return to origin (alarm already active)");
  CoilReset clear_setup(client_, Coil::SETUP);
  client_.write_coil(Coil::SETUP, true);
  const TimePoint start = client_.clock().now();
  for (;;) {
    // Flags first: the state read after them is at least as new.
    const auto flags = client_.read_flags();
    const auto state = client_.read_state();
    const Duration elapsed = client_.clock().now() - start;
    if (wait.progress) wait.progress({state, flags, elapsed});
    if (flags.alarm()) raise_alarm(flags, "return to origin");
    if (flags.seton() && !flags.busy()) return MoveResult{flags.inp(), state, flags, elapsed};
    check_cancel(wait);
    check_deadline(deadline, "return to origin");
  }
}

MoveResult Actuator::wait_until_idle(std::optional<int32_t> target, TimePoint deadline,
                                     const WaitOptions& wait) {
  const TimePoint start = client_.clock().now();
  bool seen_busy = false;
  for (;;) {
    const auto flags = client_.read_flags();
    const auto state = client_.read_state();
    const Duration elapsed = client_.clock().now() - start;
    if (wait.progress) wait.progress({state, flags, elapsed});
    if (flags.alarm()) raise_alarm(flags, "the move");
    if (flags.busy()) {
      seen_busy = true;
    } else if (seen_busy || !target || state.target_001mm == *target) {
      // BUSY fell (or the move was over before the first poll, which the
      // target shows): completion. INP now tells success (digest §5).
      return MoveResult{flags.inp(), state, flags, elapsed};
    }
    check_cancel(wait);
    check_deadline(deadline, "the move");
  }
}

MoveResult Actuator::run_step(unsigned step, TimePoint deadline, const WaitOptions& wait) {
  const auto controls = client_.read_controls();
  require_serial_mode(controls);
  const auto data = client_.read_step(step);
  if (data.is_blank()) {
    throw InvalidRequest(fmt::format(
        "step {} is blank (not registered): set it first with `lec step set {} ...`", step, step));
  }
  std::optional<int32_t> target;
  if (data.movement_mode == lec::MovementMode::Absolute && !data.is_pushing())
    target = data.position_001mm;
  // DRIVE starts on a rising edge: make sure it is low first.
  if (controls.test(Coil::DRIVE)) client_.write_coil(Coil::DRIVE, false);
  client_.select_step(step);
  CoilReset clear_drive(client_, Coil::DRIVE);
  // Writing DRIVE = 1 again after a lost reply is harmless: it is a level,
  // and a repeat makes no new edge. So even INC steps cannot start twice.
  client_.write_coil(Coil::DRIVE, true);
  return wait_until_idle(target, deadline, wait);
}

MoveResult Actuator::move(const DirectMove& m, TimePoint deadline, const WaitOptions& wait,
                          bool no_wait) {
  const auto current = client_.read_direct();
  const lec::StepData want = merge_direct(current, m);
  const auto issues = lec::validation_messages(want, std::nullopt);
  if (!issues.empty()) throw InvalidRequest(issues.front());

  // Only the registers that change are written (one contiguous range).
  const auto have_regs = current.to_registers();
  const auto want_regs = want.to_registers();
  unsigned first = lec::StepData::kRegisters, last = 0;
  for (unsigned i = 0; i < lec::StepData::kRegisters; ++i) {
    if (have_regs[i] != want_regs[i]) first = std::min(first, i), last = i;
  }
  if (first < lec::StepData::kRegisters)
    client_.write_direct_registers(want, first, last - first + 1);

  const bool relative = want.movement_mode == lec::MovementMode::Incremental;
  std::optional<int32_t> target;
  if (!relative && !want.is_pushing()) target = want.position_001mm;
  if (relative) {
    // An INC start is never resent blindly: a repeat would move twice. After a
    // lost reply, the target position tells whether the controller started.
    const auto before = client_.read_state();
    const int32_t expected = before.target_001mm + want.position_001mm;
    try {
      client_.write_direct_start(Retry::Never);
    } catch (const TransportError& e) {
      if (e.kind() == TransportErrorKind::Port || e.kind() == TransportErrorKind::EchoMismatch)
        throw;
      const auto after = client_.read_state();
      if (after.target_001mm != expected) client_.write_direct_start(Retry::Never);
    }
    if (!want.is_pushing()) target = expected;
  } else {
    client_.write_direct_start(Retry::Safe);
  }
  if (no_wait) {
    const auto flags = client_.read_flags();
    return MoveResult{flags.inp(), client_.read_state(), flags, {}};
  }
  return wait_until_idle(target, deadline, wait);
}

MoveResult Actuator::jog(bool plus, TimePoint until, TimePoint deadline, const WaitOptions& wait) {
  require_serial_mode(client_.read_controls());
  const Coil coil = plus ? Coil::JOG_PLUS : Coil::JOG_MINUS;
  CoilReset release(client_, coil);
  client_.write_coil(coil, true);
  const TimePoint start = client_.clock().now();
  while (client_.clock().now() < until && !(wait.cancel && wait.cancel())) {
    const auto flags = client_.read_flags();
    const auto state = client_.read_state();
    if (wait.progress) wait.progress({state, flags, client_.clock().now() - start});
    if (flags.alarm()) raise_alarm(flags, "jog");
  }
  client_.write_coil(coil, false);
  // Wait for the deceleration to finish: speed 0 and BUSY low.
  for (;;) {
    const auto flags = client_.read_flags();
    const auto state = client_.read_state();
    if (!flags.busy() && state.speed_mm_s == 0) {
      return MoveResult{flags.inp(), state, flags, client_.clock().now() - start};
    }
    check_deadline(deadline, "jog (stopping)");
  }
}

void Actuator::hold(bool on) {
  client_.write_coil(Coil::HOLD, on);
}

void Actuator::stop() {
  pulse(Coil::RESET);
}

std::vector<uint8_t> Actuator::reset_alarms() {
  pulse(Coil::RESET);
  return active_alarms(client_.read_flags());
}

}  // namespace lec6::client
