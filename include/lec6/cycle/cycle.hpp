#pragma once
// A machine cycle (issue 34): the axes of a cell, their named points, the
// interlocks and the steps, as read from a cycle file (docs/cycles.md) by
// parse_cycle() (cycle_file.hpp). Plain data: the Engine (engine.hpp)
// decides, the Runner (runner.hpp) talks to the controllers.
//
// Every value here has been checked when the file was read: a Cycle that
// exists names only known axes, points and branches, its absolute targets
// lie within the axes' soft limits, no parallel group moves an axis twice,
// and every wait has a timeout (tests/cycle/cycle_file_test.cpp).

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "lec6/client/actuator.hpp"
#include "lec6/clock.hpp"
#include "lec6/lec/flags.hpp"

namespace lec6::cycle {

// Where a thing was written in the file (1-based; 0: not from a file).
struct Mark {
  int line = 0;
  int column = 0;
};

struct Axis {
  std::string name;
  std::string line;  // the port it is on ("" : the port given on the command line)
  uint8_t id = 1;
  std::map<std::string, int32_t> points_001mm;
  std::optional<client::SoftLimits> soft_limits;
  std::optional<double> twin_workpiece_mm;  // --port sim only: a workpiece for pushes
  Mark mark;
};

// "axis Z above 50 mm before X moves": checked before every step that moves
// `before_moving`.
struct UserInterlock {
  std::string before_moving;
  std::string axis;
  std::optional<int32_t> above_001mm;
  std::optional<int32_t> below_001mm;
  std::string text;  // "z above 50.00 mm before x moves"
  Mark mark;
};

// What ended a step for one axis, as conditions name it.
enum class Outcome {
  Reached,     // a move, a stored step: at the target
  Pushed,      // a push met the workpiece
  PushMissed,  // a push moved its whole distance without contact
  Alarm,       // the controller raised an alarm
  Timeout,     // a wait or a move ran past its timeout
  Stopped,     // stopped (a stop request, another master, ESTOP)
  NotStarted,  // the controller did not act on the start
  Refused,     // refused before anything was written (not ready, soft limits)
  Done,        // a wait or a dwell ended as asked
  LineFault,   // its axis stopped answering: the cycle ended (no condition can catch it)
};
// "reached", "pushed", "push_missed", "alarm", "timeout", "stopped", "not_started", "refused",
// "done", "line_fault"; outcome_from_name knows all but line_fault (what `on:` may name).
std::string_view outcome_name(Outcome o) noexcept;
std::optional<Outcome> outcome_from_name(std::string_view name) noexcept;

// Where a condition sends the cycle: continue, abort, or a named branch
// (whose steps run, then the cycle goes on after the step that branched).
struct Target {
  enum Kind { Continue, Abort, Branch } kind = Continue;
  std::string branch;
};

struct Step {
  enum class Kind { Move, Push, RunStep, Wait, Dwell, Parallel, Repeat };
  Kind kind = Kind::Move;
  std::string axis;          // Move, Push, RunStep, Wait (empty: a wait for time)
  client::DirectMove move;   // Move, Push: the direct data (lec move's defaults)
  std::string point;         // the point it goes to, when named
  unsigned stored_step = 0;  // RunStep
  // Wait: a status flag (X40–X4F) to reach `flag_value`, or the position
  // above/below a value; none of them: wait until `timeout` (a time wait).
  std::optional<lec::StatusFlags::Bit> flag;
  bool flag_value = true;
  std::optional<int32_t> above_001mm;
  std::optional<int32_t> below_001mm;
  Duration timeout{};  // Wait: its timeout; Move/Push/RunStep: how long the motion may take
  Duration dwell{};    // Dwell
  unsigned times = 1;  // Repeat: its passes (with `until`: at most)
  // Repeat: ends after a pass when its axis's condition holds (axis, flag or
  // above/below, as a wait's), else after `times` passes, failing the cycle.
  bool until = false;
  std::vector<Step> steps;       // Parallel members, Repeat body
  std::map<Outcome, Target> on;  // conditions on this step's outcome
  std::string text;              // "move x to pick (120.00 mm)": for reports
  Mark mark;

  // A wait's or a repeat's condition on its axis's flags and position.
  bool condition_met(const lec::StatusFlags& flags, int32_t position_001mm) const noexcept {
    if (flag) return flags.test(*flag) == flag_value;
    if (above_001mm) return position_001mm > *above_001mm;
    if (below_001mm) return position_001mm < *below_001mm;
    return false;
  }

  bool moves() const noexcept {
    return kind == Kind::Move || kind == Kind::Push || kind == Kind::RunStep;
  }
};

// A fault for the twin to act out (`faults:` in the file, `--fault` on the
// command line), so that a cycle's failure branches run before the machine
// exists. Only `--port sim` injects them; on a line they are ignored.
struct Fault {
  enum class Kind {
    PushMiss,  // the axis's workpiece is taken away before the step starts: its push misses
    Alarm,     // the axis raises `alarm_code` once the step's starts were sent
    CutOff,    // the axis's controller stops answering once the step's starts were sent
  };
  Kind kind = Kind::Alarm;
  std::string axis;
  std::string step;   // the step's path without its pass: "6", "4.2", "no_part.1"
  unsigned pass = 1;  // the Nth time that step runs
  uint8_t alarm_code = 149;
  std::string text;  // "alarm 149 on z at step 3"
  Mark mark;
};

struct Cycle {
  std::string name;
  std::string source;  // the file it came from
  std::vector<Axis> axes;
  std::vector<UserInterlock> interlocks;
  std::vector<Step> steps;
  std::map<std::string, std::vector<Step>> branches;
  unsigned repeat = 1;        // the whole cycle, N times
  std::vector<Fault> faults;  // --port sim only

  const Axis* axis(std::string_view name) const;
};

}  // namespace lec6::cycle
