#pragma once
// Everything the twin decides where the manual is silent, in one place.
//
// `ActuatorConfig` and `LineConfig` are the twin's settings (each field has a
// default; `lec sim --help` prints them). The `behaviour` namespace holds the
// fixed decisions ("assumed" in the digest, docs/protocol-decisions.md), each
// citing the digest section it implements.
//
// docs/twin-fidelity.md (the fidelity ledger) lists every behaviour a master
// can observe, with its source (manual, field evidence, or assumption), the
// code that implements it and how to confirm it with a capture of a real
// controller. A change here changes a ledger row: update both.
//
// Thread safety: value types and pure functions; const objects may be shared between threads,
// writes need the caller's synchronisation.

#include <cstdint>
#include <optional>
#include <string>

#include "lec6/clock.hpp"
#include "lec6/modbus/timing.hpp"

namespace lec6::sim {

// A closed range [lo, hi] in mm (either order is accepted).
struct RangeMm {
  double lo = 0.0;
  double hi = 0.0;
  bool contains(double x) const noexcept {
    const double a = lo < hi ? lo : hi;
    const double b = lo < hi ? hi : lo;
    return a <= x && x <= b;
  }
};

// One actuator + controller (digest §6). Positions are in the homed
// coordinate (mm): 0 is the origin, where return to origin ends.
struct ActuatorConfig {
  // Stroke ends, mm, in the homed coordinate. Targets outside are refused
  // with alarm 52 (step) / 62 (direct). Return to origin drives to the min
  // end, then to 0 if min < 0; so min ≤ 0 ≤ max is required.
  double stroke_min_mm = 0.0;
  double stroke_max_mm = 400.0;
  // Speed and acceleration limits; larger step values are clamped to them.
  double max_speed_mm_s = 1000.0;
  double max_accel_mm_s2 = 10000.0;
  // JOG−/JOG+ speed and the acceleration/deceleration used to start/stop a jog.
  double jog_speed_mm_s = 50.0;
  double jog_accel_mm_s2 = 1000.0;
  // Return to origin (SETUP): speed and acceleration/deceleration.
  double origin_speed_mm_s = 20.0;
  double origin_accel_mm_s2 = 1000.0;
  // Where the carriage physically stands at power-on (homed coordinate, mm).
  // Before the first homing the reported position counts from here (reads 0).
  double initial_position_mm = 10.0;
  // A workpiece (rigid obstacle) at this position, mm; none by default.
  // Pushing meets it; a positioning move or homing that runs into it stalls
  // there and raises alarm 149 (positioning) / 97 (homing) after
  // `stall_alarm_delay`.
  std::optional<double> workpiece_mm;
  Duration stall_alarm_delay = std::chrono::milliseconds(1000);
  // The controller's W-AREA setting; X4D WAREA = 1 while the position is in
  // it. None by default (WAREA always 0), so power-on replies match the manual.
  std::optional<RangeMm> warea_mm;
  // Time from SVON ← 1 to SVRE = 1.
  Duration svre_delay = std::chrono::milliseconds(50);
  // Thrust model (D9003, %): while moving, friction_thrust_pct plus
  // accel_thrust_pct × |acceleration| / max_accel_mm_s2; 0 at rest; capped by
  // the step's moving force while positioning, equal to the pushing force
  // while pressing on the workpiece.
  double friction_thrust_pct = 10.0;
  double accel_thrust_pct = 50.0;
  // Wear (issue 26): every metre the carriage travels adds this many % to
  // its thrust (friction) and takes it off its speed (the drive runs slower
  // against it), so a repeated move grows longer and needs more thrust. 0:
  // never wears. E.g. 0.5 %/m: +10 % after 20 m.
  double wear_pct_per_m = 0.0;
  // Equipment name at D000E (≤ 14 ASCII characters), unless a state file has one.
  std::string equipment_name = "LEC6-TWIN";

  // ---- Field quirks (all off by default; `lec sim --profile`, issue 12) ----
  // A real controller can be slower than the digest's twin. With these on,
  // a master that judges a move from one sample is caught the way it would be
  // on a machine.
  //
  // BUSY rises this long after the controller took a start (DRIVE rising,
  // a D9100 write, SETUP rising), measured from the instant it acted on the
  // query (its reply leaves T0 + Td later). Until then the start is pending:
  // BUSY, INP, OUT0–OUT5 keep their old values, the carriage does not move
  // and a running move keeps running. All start checks (alarms 48–99) happen
  // when BUSY would rise. RESET, SVON ← 0, ESTOP and alarms cancel a pending start.
  Duration busy_delay{};
  // The shortest BUSY pulse: a move or homing that ends sooner (already at
  // its target) keeps BUSY = 1 and INP = 0 until this long after BUSY rose.
  // Stops (RESET, alarm, servo off) end BUSY at once, as before.
  Duration busy_min{};
  // D9004 (target) and D9006 (step No.) change when BUSY rises instead of
  // when the start is taken, so a master cannot lean on the target register
  // alone. Only matters with a busy_delay.
  bool target_update_late = false;
  // INP rises this long after BUSY fell at the end of a positioning move or
  // a return to origin that ended in position (the drive settling inside its
  // band; issue 32: the settle time). 0: with BUSY's fall. A push's INP (its
  // contact) is not delayed.
  Duration inp_delay{};

  // ---- Assumptions the manual leaves open (issue 33) ----------------------
  // Each is a profile key (docs/twin-fidelity.md names its row, its source and
  // the capture that settles it). The defaults here are the manual's ideal
  // (ideal_config()); the default twin of `lec sim` is default_config().
  //
  // Return to origin seeks this stroke end first (then drives to the origin 0
  // when it is not there): the time a cold start's homing takes.
  enum class HomingDirection { MinEnd, MaxEnd };
  HomingDirection homing_direction = HomingDirection::MinEnd;
  // SETON while a later return to origin runs: kept (1 throughout) or
  // cleared when BUSY rises and set again at its end.
  enum class SetonOnRehome { Keep, Clear };
  SetonOnRehome seton_on_rehome = SetonOnRehome::Keep;
  // RESET (no alarm) cancels a return to origin under way; false: RESET is
  // ignored while homing (the homing runs to its end).
  bool reset_cancels_homing = true;
  // A start while a move runs: re-plan smoothly from the current state, or
  // decelerate to rest first, then start toward the new target.
  enum class Retarget { Replan, StopThenStart };
  Retarget retarget = Retarget::Replan;
  // X4F ALARM: 1 = alarm present (the manual's "positive logic", §10.3), or
  // inverted (0 = alarm present), as two field drivers read it.
  enum class AlarmPolarity { ActiveHigh, ActiveLow };
  AlarmPolarity alarm_polarity = AlarmPolarity::ActiveHigh;
  // SETUP left at 1 after a return to origin: ignored (only its rising edge
  // acts), or DRIVE / D9100 starts are ignored until SETUP ← 0.
  enum class SetupLeftHigh { Ignored, RefusesStarts };
  SetupLeftHigh setup_left_high = SetupLeftHigh::Ignored;
};

// The manual's ideal controller (every quirk off, the digest's behaviour):
// `lec sim --ideal`. Equal to ActuatorConfig{}.
ActuatorConfig ideal_config();
// The default twin: the manual's ideal changed where the field evidence is
// strong enough (docs/protocol-decisions.md, "The default twin"): BUSY rises
// 20 ms late, shortest BUSY pulse 60 ms, homing at 50 mm/s, SETON cleared
// while a re-home runs. Tested in tests/sim/assumptions_test.cpp.
ActuatorConfig default_config();

enum class Timing {
  Real,  // reply ends at end of query + Ts + 4 ms + Td + wire time (digest §1)
  Fast,  // no artificial delay; frames also complete on expected length + CRC
};

// The serial line as the twin's controllers are set up (digest §1). All
// controllers on one twin bus share it.
struct LineConfig {
  // baud (default 38400), silent interval k (default 1: Ts = 3.5 chars),
  // minimum communication delay Td (default 5 ms). T0 is LineTiming::kProcessing.
  modbus::LineTiming line;
  Timing timing = Timing::Real;
};

namespace behaviour {

// Digest §1: the reply's last byte leaves at end of query + Ts + T0 (4 ms,
// modbus::LineTiming::kProcessing, nominal) + Td + wire time; the manual's
// ×1.5 on T0 is the master's margin, not the controller's time. A query is
// acted on (writes applied, reads sampled) when its frame is complete: at its
// last byte + Ts in real timing, at its last byte in fast timing.

// Digest §6, alarm codes: lec6::lec::alarm (lec/alarms.hpp). The twin raises
//   48 invalid data (lec::validate finds an issue in the started record),
//   51 DRIVE of a blank step, 52 step target (or pushing start) beyond the
//   stroke, 62 the same for direct operation (decision: 52 for steps, 62 for
//   direct operation), 97 return to origin stalled against the workpiece,
//   98 DRIVE / direct start while SVRE = 0, 99 ABS start before the first
//   return to origin, 149 positioning stalled against the workpiece. 97 and
//   149 are raised `stall_alarm_delay` after the carriage stalled.
// Checks on a start, first failing wins: alarm present → refused (no new
// alarm); SVRE = 0 → 98; blank step → 51; lec::validate → 48; ABS before
// homing → 99; target beyond the stroke → 52/62.

// Decision (field, issue 24; ledger R-FLAG-INP0, R-RANGE-INP): in position 0
// (D9110) is valid, although the manual prints 1…2147483647: a published driver
// written against real LECP6 hardware sends 0 and its move completes. With a
// band of 0, INP rises only exactly on the target (0.01 mm units), which is
// where every positioning profile ends; a pushing distance of 0 ends the push
// at once (INP only if the workpiece is exactly at the pushing start).

// Decision (assumed): RESET clears the alarm when lec::alarm_resettable() says
// so (48–99); other codes (149) clear only with RESET while the servo is off
// (SVON ← 0 first), so a twin never needs a restart.

// Decision (assumed): an alarm cancels the running operation with a
// decelerating stop (BUSY 0, INP 0); the servo stays on.

// Decision (assumed): step speed above max_speed_mm_s and acceleration /
// deceleration above max_accel_mm_s2 are clamped to those limits (no alarm).

// Decision (assumed): direct operation shows step No. 0 on OUT0–OUT5 and D9006.

// Decision (assumed): return to origin leaves OUT0–OUT5 and D9006 unchanged,
// sets the target (D9004) to 0 and forgets the AREA range (digest §6).

// Decision (assumed): JOG moves set BUSY = 1 while moving, INP = 0, and do
// not change the target (D9004); INC after a jog counts from the last target.

// Decision (assumed): SVON ← 0 and ESTOP stop the carriage at once (servo
// released, no deceleration modelled); SETON is kept (the encoder still knows
// where it is). After ESTOP is released, a write of SVON ← 1 (even if Y19 is
// already 1) starts the SVRE delay again.

// Decision (assumed): switching Y30 1 → 0 (back to parallel mode) clears
// Y10–Y1F, since the twin's parallel inputs are all open; the falling edges
// act as usual (servo off, jog stop, hold release).

// Decision (assumed): within one write, all coil values are stored first,
// then edges act in this order: SVON, RESET, HOLD, SETUP, DRIVE, JOG.
// Within one FC10, all registers are stored first, then D9100 acts.

// Decision (assumed): pushing into the workpiece raises thrust to the pushing
// force at contact at once (no ramp), so INP = 1, BUSY = 0 at the contact
// instant whenever trigger ≤ pushing force (validated at start, else 48).

// Decision (assumed): a start with HOLD = 1 is accepted (BUSY 1) and waits
// suspended until HOLD ← 0.

// Decision (assumed): the approach of a pushing operation ends at rest at the
// pushing start, then the pushing phase starts from rest at pushing speed
// (with the step's acceleration/deceleration) toward start ± in-position
// (clamped to the stroke).

// Decision (assumed): a JOG release decelerates with jog_accel_mm_s2 and BUSY
// falls when the carriage is at rest; RESET cancels with BUSY 0 at once.

// Decision (assumed): SETON stays 1 while a later return to origin runs.

// Decision (assumed): RESET with no alarm also ends a pushing hold against the
// workpiece (thrust 0, INP 0).

// Decision (assumed): a frame with a good CRC and a known function whose
// byte count disagrees with its length gets exception 03; a frame whose
// length does not fit its function gets no reply.

// Thrust caps (%) for the operations that have no moving force of their own.
inline constexpr double kHomingThrustPct = 100.0;
inline constexpr double kJogThrustPct = 100.0;

}  // namespace behaviour

}  // namespace lec6::sim
