// The operation sequences that prepare and hold an axis (serial mode, servo,
// return to origin, jog, hold, stop, alarms) and the poll loop every move
// ends in. Moves are in actuator_move.cpp; the rule that ends one is
// completion.cpp.

#include <fmt/format.h>

#include <algorithm>

#include "client/coil_reset.hpp"
#include "client/wire_dated.hpp"
#include "lec6/client/actuator.hpp"
#include "lec6/lec/alarms.hpp"
#include "lec6/lec/units.hpp"

namespace lec6::client {
namespace {

using lec::Coil;

// Between polls that failed while a grace runs (WaitOptions::unanswered_grace):
// a backed-off controller refuses at once, and the wait must not spin.
constexpr Duration kUnansweredPause = std::chrono::milliseconds(50);

std::string codes_text(const std::vector<uint8_t>& codes) {
  std::string out;
  for (uint8_t c : codes)
    out += fmt::format("{}{} ({})", out.empty() ? "" : ", ", c, lec::alarm_meaning(c));
  return out.empty() ? "no code in the history" : out;
}

}  // namespace

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
  throw AlarmError(codes, fmt::format("the controller raised an alarm during {}: {}; {}", during,
                                      codes_text(codes), lec::alarm_clear_hint(codes)));
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
  try {
    client_.write_coil(coil, true);
  } catch (...) {
    // The 1 may have been heard with only its reply lost: release the coil all
    // the same, or it stays at 1 and the next pulse (the next stop) is no edge.
    try {
      client_.write_coil(coil, false);
    } catch (...) {  // the first error is the one to report
    }
    throw;
  }
  client_.write_coil(coil, false);
}

// Everything a start needs, read before anything is written: serial mode
// (issue 12: a refused start must not leave half-written data), no alarm,
// the servo on, and the flags and state the completion rule compares with.
Actuator::Before Actuator::ready_to_move(std::string_view what) {
  const lec::ControlFlags controls = client_.read_controls();
  require_serial_mode(controls);
  Before b{controls, client_.read_flags(), client_.read_state()};
  if (b.flags.alarm()) raise_alarm(b.flags, fmt::format("{} (alarm already active)", what));
  if (!b.flags.svre())
    throw InvalidRequest(fmt::format("{} needs the servo on (SVRE = 0): run `lec servo on`", what));
  return b;
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
  const Before before = ready_to_move("return to origin");
  // SETUP starts on a rising edge: make sure it is low first.
  if (before.controls.test(Coil::SETUP)) client_.write_coil(Coil::SETUP, false);
  detail::CoilReset clear_setup(client_, Coil::SETUP);
  client_.write_coil(Coil::SETUP, true);
  MoveGoal goal;
  goal.operation = Operation::Home;
  goal.in_position_001mm = kPositionTolerance001mm;
  return this->wait(
      StartedMove{detail::wire_dated(
          MoveStart{goal, before.flags, before.state, false, client_.clock().now()}, client_)},
      deadline, wait);
}

// Polls flags then state (flags first: the state is at least as new as the
// flags it is judged with) until the completion rule has a result.
MoveResult Actuator::poll_until_done(Completion& done, TimePoint started_at,
                                     const WaitOptions& wait) {
  try {
    bool unanswered = false;  // polls are failing now, since the start of the first
    TimePoint unanswered_since{};
    for (;;) {
      if (wait.poll_jitter) {
        if (const Duration j = wait.poll_jitter(); j > Duration::zero())
          client_.idle_until(client_.clock().now() + j);
      }
      const TimePoint began = client_.clock().now();
      lec::StatusFlags flags;
      lec::StateData state;
      TimePoint at;
      std::optional<WireTimes> wire;
      try {
        flags = client_.read_flags();
        at = client_.clock().now();
        wire = client_.last_wire_times();
        state = client_.read_state();
      } catch (const TransportError& e) {
        if (!is_line_fault(e.kind()) || wait.unanswered_grace <= Duration::zero()) throw;
        const TimePoint now = client_.clock().now();
        if (!unanswered) unanswered_since = began;
        unanswered = true;
        if (now - unanswered_since >= wait.unanswered_grace) {
          throw TransportError(e.kind(),
                               fmt::format("{} (the move's polls went unanswered for {:.1f} s; "
                                           "the axis may still be moving)",
                                           e.what(), to_seconds(now - unanswered_since)));
        }
        if (wait.cancel && wait.cancel()) stop_after_interrupt(done.interrupted());
        client_.idle_until(now + std::max(wait.poll_interval, kUnansweredPause));
        continue;
      }
      unanswered = false;
      if (wait.progress) wait.progress({state, flags, at - started_at});
      if (auto r = done.feed(detail::wire_dated(Poll{flags, state, at}, wire))) return *r;
      if (wait.cancel && wait.cancel()) stop_after_interrupt(done.interrupted());
      if (wait.poll_interval > Duration::zero()) client_.idle_until(began + wait.poll_interval);
    }
  } catch (const Cancelled& e) {
    if (e.move_result()) throw;
    stop_after_interrupt(done.interrupted());  // Ctrl-C reached the line's wait
  }
}

// Ctrl-C or cancel(): stop the axis (the line lets stop requests through,
// see client/interrupt.hpp), then report how far it got.
void Actuator::stop_after_interrupt(const MoveResult& r) {
  try {
    stop();
  } catch (const TransportError& e) {
    throw TransportError(e.kind(), fmt::format("interrupted, and the stop (RESET pulse) could not "
                                               "be sent: {}; the axis may still be moving",
                                               e.what()));
  }
  throw Cancelled(fmt::format("interrupted: the axis was stopped (decelerating stop) at {} mm",
                              lec::format_mm(r.state.position_001mm)),
                  r);
}

// Turns the ends that are not results into their exceptions.
MoveResult Actuator::conclude(MoveResult r, std::string_view what) {
  switch (r.outcome) {
    case MoveOutcome::Alarm:
      r.alarm_codes = active_alarms(r.flags);
      throw AlarmError(r.alarm_codes, fmt::format("{}: {}", what, r.describe()), r);
    case MoveOutcome::Deadline: {
      std::string held;
      if (client_.read_controls().test(Coil::HOLD))
        held = " (HOLD is on: the operation is suspended)";
      throw DeadlineError(fmt::format("{} did not finish in time: {}{}", what, r.describe(), held),
                          r);
    }
    case MoveOutcome::NotStarted:
      // A start processed late must not run with nobody watching it.
      stop();
      throw MoveNotStarted(fmt::format("{}: {}", what, r.describe()), r);
    default:
      return r;
  }
}

MoveResult Actuator::jog(bool plus, TimePoint until, TimePoint deadline, const WaitOptions& wait) {
  require_serial_mode(client_.read_controls());
  const Coil coil = plus ? Coil::JOG_PLUS : Coil::JOG_MINUS;
  detail::CoilReset release(client_, coil);
  client_.write_coil(coil, true);
  const TimePoint start = client_.clock().now();
  try {
    while (client_.clock().now() < until && !(wait.cancel && wait.cancel())) {
      const auto flags = client_.read_flags();
      const auto state = client_.read_state();
      if (wait.progress) wait.progress({state, flags, client_.clock().now() - start});
      if (flags.alarm()) raise_alarm(flags, "jog");
    }
  } catch (const Cancelled&) {
    client_.write_coil(coil, false);  // Ctrl-C on the line: release, then report it
    throw Cancelled("interrupted: the jog was released (decelerating stop)");
  }
  client_.write_coil(coil, false);
  MoveGoal goal;
  goal.operation = Operation::Jog;
  Completion done(MoveStart{goal, {}, {}, true, start}, deadline, wait.completion);
  return conclude(poll_until_done(done, start, WaitOptions{wait.progress, {}, {}, {}}), "jog");
}

void Actuator::hold(bool on) {
  client_.write_coil(Coil::HOLD, on);
}

void Actuator::stop() {
  pulse(Coil::RESET);  // stop(kind, policy) judges it, and pulses again if it was no edge
}

std::vector<uint8_t> Actuator::reset_alarms() {
  client_.write_coil(Coil::RESET, false);  // RESET acts on its edge: a 0 first
  pulse(Coil::RESET);
  return active_alarms(client_.read_flags());
}

}  // namespace lec6::client
