#pragma once
// How a move ended, in the manual's words (issue 12): one outcome, what the
// controller showed at the end, and a timeline of the flags. Every front end
// prints MoveResult::describe(), so an engineer reads the same sentence in
// `lec move`, `lec serve` and the Python bindings.
//
// Thread safety: plain values (no references, no I/O); copies may be used
// from any thread, one writer at a time. The functions are pure.

#include <chrono>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "lec6/clock.hpp"
#include "lec6/lec/flags.hpp"
#include "lec6/lec/state_data.hpp"

namespace lec6::client {

enum class Operation {
  Positioning,  // ABS or INC, pushing force 0
  Pushing,      // pushing force > 0: approach, then push at pushing speed
  Home,         // return to origin (SETUP)
  Jog,          // JOG± released: waiting for the carriage to stop
};

enum class MoveOutcome {
  Reached,     // BUSY fell with INP = 1 and the position within the in-position band
               // (home: SETON = 1 at the origin)
  Pushed,      // pushing: the workpiece was met, thrust ≥ trigger level, INP = 1
  PushMissed,  // pushing: the whole pushing distance was moved with no contact, INP = 0
  Stopped,     // BUSY fell short of the target without an alarm (RESET, servo off,
               // ESTOP, another master, Ctrl-C, a jog released)
  Alarm,       // the controller raised an alarm (X4F = 1)
  Deadline,    // still running at the caller's deadline
  NotStarted,  // nothing showed that the controller started the move (completion.hpp)
};

// "reached", "pushed", "push_missed", "stopped", "alarm", "deadline", "not_started".
std::string_view outcome_name(MoveOutcome o) noexcept;

// Why a move stopped, as far as the flags tell.
enum class StopCause {
  Unknown,        // a stop (RESET) or another master: nothing in the flags says which
  Interrupted,    // this client stopped it (Ctrl-C, WaitOptions::cancel)
  ServoOff,       // SVRE = 0
  EmergencyStop,  // ESTOP = 1
  Released,       // a jog was released
};

// When the polls first saw each flag, from the moment the start was
// acknowledged (a flag that changed between two polls is dated by the later
// one). nullopt: not seen (a BUSY pulse shorter than the poll period).
// BUSY's rise and fall are bracketed (issue 32): each happened after the
// poll before the one that saw it (`*_after`: that poll, or 0, the start)
// and before the one that saw it, so a duration is known to ± half the two
// brackets' widths (timing_test.cpp ASixtyMsMoveReadsWithinItsBracketAtAnyPollGap).
struct MoveTimeline {
  std::optional<Duration> busy_up;
  std::optional<Duration> busy_down;
  std::optional<Duration> inp;
  std::optional<Duration> busy_up_after;    // the last poll before BUSY was seen (0: the start)
  std::optional<Duration> busy_down_after;  // the last poll that saw BUSY = 1
  std::optional<Duration> inp_after;        // the last poll before INP was seen (settle time)
  TimePoint origin{};  // the clock time these count from: the start's acknowledgement
};

// What was asked: the goal a move is judged against.
struct MoveGoal {
  Operation operation = Operation::Positioning;
  std::optional<unsigned> step;  // DRIVE of this step; nullopt: direct operation or homing
  // Positioning: the target (INC already added to the previous target);
  // pushing: the pushing start; homing: 0 (the origin).
  int32_t target_001mm = 0;
  // Positioning and homing: the in-position width, ± around the target
  // (the step's "In position" field). 0 for a push.
  int32_t in_position_001mm = 0;
  // Pushing: the pushing distance beyond the pushing start (the same
  // step field, which means this when the step pushes). 0 otherwise.
  int32_t pushing_distance_001mm = 0;
  uint16_t trigger_level_pct = 0;  // pushing
  // The profile the controller was given (the step's or the direct data's
  // speed, acceleration and deceleration, digest §6): lec serve's history
  // times a motion against it (serve/history/profile_fit.hpp). 0: not known.
  uint16_t speed_mm_s = 0, acceleration_mm_s2 = 0, deceleration_mm_s2 = 0;
  // Where the carriage stood, at rest, in the read just before the start
  // (nullopt: it was moving, or not read): the profile's start.
  std::optional<int32_t> from_001mm;
  // Direct moves with keep: the values that came from the controller, not
  // from this command ("in position 20.00 mm"); describe() names them.
  std::vector<std::string> kept;
};

struct MoveResult {
  MoveOutcome outcome = MoveOutcome::Reached;
  MoveGoal goal;
  bool in_position = false;  // INP at the end
  lec::StateData state;      // the last poll
  lec::StatusFlags flags;
  TimePoint started_at{};  // the start was acknowledged (the timeline's 0), on the Client's clock
  Duration elapsed{};      // started_at → the last poll
  MoveTimeline timeline;
  // What showed that the controller started this move ("BUSY", "OUT0–OUT5 =
  // 3", "SETON rose", "at the target, INP = 1, D9004 = target"…); empty when
  // nothing did (NotStarted).
  std::string evidence;
  std::vector<uint8_t> alarm_codes;  // Alarm: the active codes
  StopCause stop_cause = StopCause::Unknown;

  // Reached or Pushed: the move did what was asked.
  bool succeeded() const noexcept {
    return outcome == MoveOutcome::Reached || outcome == MoveOutcome::Pushed;
  }
  // One line in the manual's words, e.g. "reached 150.00 mm (INP, within
  // ±0.50 mm) in 0.70 s", "pushed: workpiece at 342.10 mm, thrust 50 % (INP)".
  // Values a `keep` move took from the controller end the line:
  // "…; kept from the controller: in position 20.00 mm".
  std::string describe() const;

 private:
  std::string outcome_text() const;
};

}  // namespace lec6::client
