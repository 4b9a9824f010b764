#pragma once
// The operation sequences of the manual (§4–§7, digest §5) on one controller,
// each bounded by a deadline:
//
//   lec6::client::Actuator axis(client);
//   axis.set_serial_mode(true);
//   axis.servo_on(axis.deadline_in(seconds(5)));
//   axis.home(axis.deadline_in(seconds(30)));
//   auto r = axis.move_to({.position_001mm = 30000}, axis.deadline_in(seconds(30)));
//
// Completion is BUSY falling; success is INP = 1 after that (digest §5).
// An alarm during an operation throws AlarmError with the active codes; a
// deadline throws DeadlineError; cancel() returning true stops the axis
// (decelerating) and throws Cancelled.

#include <chrono>
#include <functional>
#include <optional>

#include "lec6/client/client.hpp"

namespace lec6::client {

struct Progress {
  lec::StateData state;
  lec::StatusFlags flags;
  Duration elapsed;
};

struct WaitOptions {
  std::function<void(const Progress&)> progress;  // called after every poll
  std::function<bool()> cancel;                   // polled between transactions
};

struct MoveResult {
  bool in_position = false;  // INP after BUSY fell
  lec::StateData state;
  lec::StatusFlags flags;
  Duration elapsed{};
};

// A direct operation. Fields left empty keep what the controller holds in
// D9102–D9111 (the data persist between moves, digest §5); when the
// controller holds nothing valid there, the defaults below fill in.
struct DirectMove {
  std::optional<int32_t> position_001mm;
  bool relative = false;  // INC
  std::optional<uint16_t> speed_mm_s;
  std::optional<uint16_t> acceleration_mm_s2;
  std::optional<uint16_t> deceleration_mm_s2;
  std::optional<uint16_t> moving_force_pct;
  std::optional<int32_t> in_position_001mm;
  std::optional<int32_t> area1_001mm;
  std::optional<int32_t> area2_001mm;
  std::optional<uint16_t> pushing_force_pct;  // > 0: pushing
  std::optional<uint16_t> trigger_level_pct;
  std::optional<uint16_t> pushing_speed_mm_s;
};

// What fills fields the user did not give when the controller's direct data
// are blank (power-on). Gentle values, documented in docs/protocol-decisions.md.
lec::StepData default_direct_data();

// Merges a DirectMove into the controller's current direct data.
lec::StepData merge_direct(const lec::StepData& current, const DirectMove& move);

class Actuator {
 public:
  explicit Actuator(Client& client) : client_(client) {}

  TimePoint deadline_in(Duration d) const { return client_.clock().now() + d; }

  void set_serial_mode(bool serial);
  void servo_on(TimePoint deadline, const WaitOptions& wait = {});
  void servo_off(TimePoint deadline, const WaitOptions& wait = {});
  // SETUP ← 1, wait SETON = 1 and BUSY = 0, SETUP ← 0 (always, also on failure).
  MoveResult home(TimePoint deadline, const WaitOptions& wait = {});
  // IN0–IN5 ← step, DRIVE ← 1, wait BUSY to fall, DRIVE ← 0.
  MoveResult run_step(unsigned step, TimePoint deadline, const WaitOptions& wait = {});
  // Writes only the direct-data registers that change, starts, and waits.
  // With `no_wait` it returns right after the start (result holds the state then).
  MoveResult move(const DirectMove& move, TimePoint deadline, const WaitOptions& wait = {},
                  bool no_wait = false);
  // JOG± ← 1 until `until` or cancel(), then ← 0; waits for the axis to stop.
  MoveResult jog(bool plus, TimePoint until, TimePoint deadline, const WaitOptions& wait = {});
  void hold(bool on);
  // Decelerating stop: a RESET pulse with no alarm active cancels the operation.
  void stop();
  // RESET pulse; returns the codes still active afterwards (not resettable).
  std::vector<uint8_t> reset_alarms();
  // The codes of the alarm being generated (history group 0) when ALARM = 1.
  std::vector<uint8_t> active_alarms(const lec::StatusFlags& flags);

  // Waits for BUSY to fall after a start whose expected target is `target`.
  MoveResult wait_until_idle(std::optional<int32_t> target, TimePoint deadline,
                             const WaitOptions& wait);

 private:
  void require_serial_mode(const lec::ControlFlags& controls);
  void pulse(lec::Coil coil);
  [[noreturn]] void raise_alarm(const lec::StatusFlags& flags, std::string_view during);
  void check_cancel(const WaitOptions& wait);
  void check_deadline(TimePoint deadline, std::string_view what);

  Client& client_;
};

}  // namespace lec6::client
