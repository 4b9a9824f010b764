#pragma once
// An axis' commands as DCMD metric writes (docs/sparkplug.md), turned into
// the commands the HTTP API and the MQTT bridge run (ops/commands.hpp), so
// they are checked by the same rules and run by Operations the same way:
//
//   Command/Stop = true          stop: runs at once, whatever else the DCMD holds
//                                (the rest is not run: "only the stop ran")
//   Command/Hold = true|false    HOLD on / off
//   Command/Reset = true         reset
//   Command/Serial = true|false  serial mode on / off
//   Command/Servo = true|false   servo on / off
//   Command/Home = true          home
//   Command/Run Step = N         run stored step N (0-63)
//   Command/Move/Position mm, Speed mm/s, Accel mm/s2, Decel mm/s2, Force %, Relative:
//                                the next move's settings (kept, published)
//   Command/Move/Execute = true  move with the settings (those of this DCMD included)
//
// One action per DCMD. Anything wrong (two actions, a setting out of range,
// Execute without a position) refuses the whole DCMD: no setting is kept,
// nothing runs, and Command/Outcome = "refused" with Command/Message why.
//
// Tests: tests/serve/sparkplug/dcmd_test.cpp (SparkplugDcmd.*), and over the
// broker integration.sparkplug_host (a stop stops a moving axis, bad DCMDs refused).
//
// Thread safety: pure functions.

#include <deque>
#include <optional>
#include <string>
#include <vector>

#include "ops/commands.hpp"
#include "sparkplug/session.hpp"

namespace lec6::serve::sparkplug {

struct MoveSettings {
  std::optional<double> position_mm;
  std::optional<int64_t> speed_mm_s, accel_mm_s2, decel_mm_s2, force_pct;
  bool relative = false;
  bool operator==(const MoveSettings&) const = default;
};

// What the device publishes of its commands.
struct CommandState {
  MoveSettings move;
  std::string outcome = "none";  // none, set, running, done, failed, refused
  std::string message;
  int64_t status = 0;  // the HTTP-style status of ops/operations.hpp (0: none yet)
  int64_t count = 0;   // DCMDs handled: every one changes it, so each gets a DDATA
  // The last stop's result: none, running, done, failed.
  std::string stop_outcome = "none";
  std::string stop_message;
  int64_t stop_count = 0;  // the DCMD number of that stop
  // The settings as kept for good, and the writes of DCMDs whose action has
  // not settled yet, in their order: `move` is `kept` with them applied. A
  // DCMD whose action Operations refuses before the wire takes its own writes
  // out, and only them (settle_settings()); a field it wrote that a later
  // DCMD wrote too keeps the later value.
  struct PendingSettings {
    int64_t count = 0;
    uint8_t written = 0;  // bits: position, speed, accel, decel, force, relative
    MoveSettings values;
    bool kept = false;  // its action ran (or it had none): folded once those before it are
  };
  MoveSettings kept;
  std::deque<PendingSettings> pending;
};

struct Plan;
// DCMD `count`'s writes (plan.written, with plan.move's values) join the settings.
void record_settings(CommandState& s, int64_t count, const Plan& plan);
// DCMD `count` was refused before the wire (true) or ran (false): its settings
// are given back or kept for good.
void settle_settings(CommandState& s, int64_t count, bool refused);

// The writable metrics, in the order axis_metrics() lists them.
std::vector<MetricDef> command_metrics();

struct Plan {
  MoveSettings move;               // the settings once this DCMD is applied
  uint8_t written = 0;             // which of them this DCMD wrote (CommandState::PendingSettings)
  std::optional<Command> command;  // the action to run, if any
  std::string note;                // "only the stop ran" and the like
};

// `writes` index command_metrics() (not the device's whole list).
Expected<Plan, std::string> plan(const std::vector<Write>& writes, const MoveSettings& current);

}  // namespace lec6::serve::sparkplug
