#pragma once
// Commands to an axis as the HTTP API and the MQTT bridge take them: an op
// name and JSON arguments in the manual's units, checked completely before
// anything reaches the line. A mistake names the field and the rule:
//   {"field": "speed_mm_s", "error": "speed: 70000 is outside 1 to 65535 mm/s"}
//
//   op          arguments (all optional unless marked)
//   serial      on (bool, required)
//   servo       on (bool, required)
//   home        timeout_s
//   move        position_mm (required, unless step), relative, speed_mm_s,
//               accel_mm_s2, decel_mm_s2, moving_force_pct, in_position_mm,
//               area1_mm + area2_mm, push_pct, trigger_pct, push_speed_mm_s,
//               timeout_s;  or step (0–63) to run a stored step
//   jog         direction ("+" / "-", required), and either lease_ms (hold to
//               run: renewed by repeating the command, released by
//               jog-stop, the stream closing or the lease running out) or
//               duration_ms (a timed jog)
//   jog-stop    —
//   hold        on (bool, required)
//   stop        —
//   reset       —
//   step-read   step (0–63; absent: all 64)
//   step-write  step (0–63, required) and the fields to change, by the CSV
//               column names (speed_mm_s, position_mm, …) or the CLI's
//               (speed, position, …), in the same units; the step's other
//               fields keep their values
//
// Thread safety: pure functions.

#include <map>
#include <optional>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

#include "lec6/client/actuator.hpp"
#include "lec6/clock.hpp"
#include "lec6/expected.hpp"
#include "lec6/lec/step_data.hpp"

namespace lec6::serve {

enum class Op {
  Serial,
  Servo,
  Home,
  Move,
  RunStep,
  Jog,
  JogStop,
  Hold,
  Stop,
  Reset,
  StepRead,
  StepWrite,
};
std::string_view op_name(Op op) noexcept;
// Ops that move the axis: one at a time per axis.
bool is_motion(Op op) noexcept;

struct Command {
  Op op = Op::Stop;
  bool on = false;               // serial, servo, hold
  client::DirectMove move;       // move
  std::optional<unsigned> step;  // move by step, step-read, step-write
  Duration timeout = std::chrono::seconds(60);
  bool jog_plus = true;                      // jog
  Duration jog_lease{};                      // jog hold-to-run
  Duration jog_duration{};                   // jog for a while
  std::map<lec::StepField, int64_t> fields;  // step-write: raw values to change
  // The latest moment it may start (the steady clock): a command whose channel has a
  // freshness rule (MQTT's valid_for) and that waits for a stop accepted
  // before it is refused (408) once this passes, nothing sent. nullopt: none.
  std::optional<TimePoint> start_by;
};

struct CommandError {
  std::string field;  // the JSON key at fault ("" for the op itself)
  std::string message;
};

// Parses and checks one command. `args` is a JSON object (or null for none).
Expected<Command, CommandError> parse_command(std::string_view op, const nlohmann::json& args);
// Stop, reset and HOLD on (not HOLD off: it resumes motion): taken from every
// channel at any time (shutdown included), never refused as stale or busy
// (issue 31 rules 4 and 5): a late stop never moves an axis.
bool stops_motion(const Command& cmd) noexcept;

}  // namespace lec6::serve
