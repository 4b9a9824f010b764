#pragma once
// A stop judged by the axis, not by the write (issue 31 rule 1;
// docs/protocol-decisions.md, "A stop is judged by the axis").
//
// RESET and HOLD act on their edge: a write of 1 over a 1 (an HMI or a PLC
// that left the coil set) is no edge and stops nothing. So a stop pulses
// RESET (1 then 0, nothing read first: a read would wait behind other
// clients, and a 0 first would cost a controller whose replies are lost a
// whole write's attempts); if the axis still moves, RESET was at 1 before
// it, and the pulse left it at 0: a second pulse is an edge. A hold writes
// HOLD <- 1 and never HOLD <- 0
// (that would resume a held operation: a HOLD left at 1 with the axis still
// moving is reported, and escalated by the policy). Then it watches the axis:
// "stopped at X mm" only when a read shows it at rest
// (speed 0, and BUSY 0 for a stop; a held axis keeps BUSY). If the axis is
// not at rest within the time its speed needs at the deceleration (plus a
// margin), the stop escalates by the policy: HOLD, then servo off where
// allowed; and the report says what happened, "still moving" included.
//
//   client::Actuator act(c);
//   auto r = act.stop(client::StopKind::Stop, {});
//   if (!r.stopped) ...  // r.describe(): "stop sent (...); the axis is still moving at 20 mm/s"
//
// Attacked by tests/client/stop_judge_test.cpp (a RESET left at 1, a HOLD left
// at 1, an axis that ignores RESET, a controller that stops answering, an
// axis at rest) on the twin and the virtual clock.

#include <string>
#include <vector>

#include "lec6/clock.hpp"
#include "lec6/lec/flags.hpp"
#include "lec6/lec/state_data.hpp"

namespace lec6::client {

enum class StopKind : uint8_t {
  Stop,  // RESET pulse: decelerating stop, the operation is cancelled
  Hold,  // HOLD <- 1: decelerating stop, the operation is suspended (HOLD <- 0 resumes it)
};

struct StopPolicy {
  // The deceleration the axis stops with; 0: not known here, assume
  // `assumed_decel_mm_s2` (the time allowed is speed / deceleration + margin).
  unsigned decel_mm_s2 = 0;
  unsigned assumed_decel_mm_s2 = 500;
  Duration margin = std::chrono::milliseconds(300);
  bool escalate_hold = true;  // a stop that did not stop: HOLD <- 1 (left on; said so)
  bool escalate_servo_off =
      false;  // then SVON <- 0 (the axis coasts or brakes: configure knowingly)
  Duration deadline = std::chrono::seconds(10);  // the whole judgement, at most
};

struct StopReport {
  StopKind kind = StopKind::Stop;
  bool stopped = false;              // a read showed the axis at rest after the stop
  bool answered = false;             // at least one read of the axis came back
  std::vector<std::string> actions;  // what was written, in order, in the manual's terms
  lec::StatusFlags flags;            // the last read
  lec::StateData state;
  Duration took{};  // from the first write to the read that showed it at rest (or the last read)
  std::string problem;  // a write or read that failed, in the user's terms
  // "stopped at 12.30 mm after 0.12 s (RESET pulse)", or "stop sent (RESET
  // pulse, then HOLD <- 1); the axis is still moving at 20 mm/s at 12.30 mm".
  std::string describe() const;
};

}  // namespace lec6::client
