#pragma once
// Calibration (issue 24, `lec sim --calibrate FILE`): fits the twin's
// parameters to a capture of a real controller, sans-I/O. From the exchanges
// of a capture (replay.hpp) it fits:
//   - response time: Td (the median of reply end − query end − Ts − T0 − the
//     reply's wire time) and lateness (the share of replies later than that by
//     over 1 ms, and their median extra delay);
//   - BUSY delay: per move, when the carriage started (the motion fit) after
//     the controller acted on the start (end of the start query + Ts);
//   - the shortest BUSY pulse: moves already at their target, bounded by the
//     flag polls around BUSY's fall (intersected over all such moves);
//   - the motion profile: per move, effective speed, acceleration and
//     deceleration fitted (least squares, Nelder-Mead) to the sampled
//     positions; a direct move whose fitted value is clearly below what was
//     commanded shows the actuator's limit (max speed / max acceleration);
//   - homing: time from SETUP to the end, and the origin speed (D9002, else
//     the position reads D9000), the homing direction, and whether SETON
//     falls while a re-home runs (issue 33);
//   - retargets: whether a start while a move runs re-plans smoothly or
//     stops the carriage first (speed D9002 or positions, issue 33);
//   - the thrust scale: D9003 read while moving against the fitted profile's
//     acceleration (a line: friction share + acceleration share);
// and says what it could not determine from this capture. Samples are dated
// as the twin samples them: at the end of the read query + Ts.
//
// Thread safety: value types and pure functions.

#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "lec6/modbus/timing.hpp"
#include "lec6/twin/replay.hpp"

namespace lec6::twin {

// One fitted parameter, named by its key in a field profile.
struct FittedParameter {
  std::string key;  // "actuator.busy_delay_ms", "line.delay_ms", …
  double value = 0;
  double spread = 0;  // ± (half the interval, or the standard deviation of the estimates)
  std::size_t samples = 0;
  std::string unit;
  std::string note;  // how it was found
};

// The motion fit of one move.
struct MoveFit {
  std::size_t line = 0;   // the start query's line in the capture
  std::string operation;  // "direct move", "step move", "return to origin"
  double from_mm = 0, to_mm = 0;
  std::optional<double> commanded_speed_mm_s, commanded_accel_mm_s2, commanded_decel_mm_s2;
  double start_delay_ms = 0;  // carriage start − controller acted on the start
  double speed_mm_s = 0, accel_mm_s2 = 0, decel_mm_s2 = 0;
  double residual_rms_mm = 0;
  std::size_t samples = 0;
};

// One behaviour chosen from a capture (a profile key with a word value, e.g.
// actuator.retarget: stop_then_start), with the evidence.
struct ChosenBehaviour {
  std::string key;
  std::string value;
  std::size_t samples = 0;  // sequences that showed it
  std::string note;
};

struct Calibration {
  modbus::LineTiming line;  // baud and k as given; delay_td as fitted (else given)
  std::vector<FittedParameter> fitted;
  std::vector<ChosenBehaviour> chosen;
  std::vector<MoveFit> moves;
  std::vector<std::string> undetermined;  // "thrust scale: no D9003 reads during a move"

  const FittedParameter* find(std::string_view key) const;
  // A field profile (profiles/, twin/field_profile.hpp) with the fitted keys;
  // each commented with its spread and sample count.
  std::string profile_yaml(const std::string& name, const std::string& source) const;
  // Residuals, per-move fits and what could not be determined, for a person.
  std::string summary() const;
};

// `line`: the capture's baud and silent interval k (its header); Td is fitted.
Calibration calibrate(std::span<const Exchange> exchanges, const modbus::LineTiming& line);

}  // namespace lec6::twin
