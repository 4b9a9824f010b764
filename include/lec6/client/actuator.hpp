#pragma once
// The operation sequences of the manual (§4–§7, digest §5) on one controller,
// each bounded by a deadline:
//
//   lec6::client::Actuator axis(client);
//   axis.set_serial_mode(true);
//   axis.servo_on(axis.deadline_in(seconds(5)));
//   axis.home(axis.deadline_in(seconds(30)));
//   auto r = axis.move({.position_001mm = 30000}, axis.deadline_in(seconds(30)));
//   std::puts(r.describe().c_str());   // "reached 300.00 mm (INP, within ±0.50 mm) in 0.70 s"
//
// Every move ends by the one rule in completion.hpp and returns a MoveResult
// (outcome and timeline): reached, pushed, push missed or stopped. The other
// ends are thrown, each carrying the MoveResult: an alarm (AlarmError), the
// deadline (DeadlineError), a start the controller never acted on
// (MoveNotStarted: the axis is stopped first), or cancel() / Ctrl-C
// (Cancelled: the axis is stopped first).
//
// Thread safety: one thread at a time, like the Client underneath. Used by
// the CLI, `lec serve` and the Python bindings: nothing here knows about them.
// Lifetime: an Actuator keeps a reference to its Client, which must outlive
// it; it holds no other state between calls, so any number of Actuators may
// be made on one Client (one at a time in use) and thrown away.

#include <chrono>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "lec6/client/client.hpp"
#include "lec6/client/completion.hpp"
#include "lec6/client/move_result.hpp"
#include "lec6/client/stop.hpp"

namespace lec6::client {

struct Progress {
  lec::StateData state;
  lec::StatusFlags flags;
  Duration elapsed;
};

struct WaitOptions {
  std::function<void(const Progress&)> progress;  // called after every poll
  std::function<bool()> cancel;                   // polled between transactions
  // From the start of one poll (flags, then state) to the start of the next,
  // waited with Client::idle_until (the line stays free for others meanwhile,
  // e.g. other threads on a SharedMaster); 0 (the default, and what `lec`
  // uses): back to back at the wire's speed.
  Duration poll_interval{};
  // Before each poll, this long more (drawn anew each time; none when
  // unset). A daemon whose axes move in step polls each at the same delay
  // after its edges every time; a few ms of jitter varies the polls' phase,
  // so that the move history's brackets narrow from both sides (issue 32).
  std::function<Duration()> poll_jitter{};
  CompletionOptions completion{};  // the start window
  // How long the polls may go unanswered on a working line (timeouts, CRC
  // and framing errors: is_line_fault) before the wait gives up with the
  // last error. A lost poll says nothing about the axis, which runs on
  // (what a daemon wants on a noisy line, whose controller is backed off a
  // few seconds: lec serve uses a grace longer than its probe interval).
  // 0 (the default, and what `lec` uses): the first poll that fails after
  // the client's retries ends the wait. The deadline ends it either way.
  Duration unanswered_grace{};
};

// A direct operation. Every move writes a complete set of direct data
// (D9102–D9111): the fields given here, and default_direct_data() for the
// rest, so a move never inherits a band, speed or force from an earlier one
// (docs/protocol-decisions.md, "Direct-operation defaults"). With keep = true
// the fields left empty keep what the controller holds instead (the data
// persist between moves, digest §5), except pushing force and trigger level:
// a move without a pushing force is a positioning move, whatever the
// previous one was. The result names each value kept (MoveGoal::kept).
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
  bool keep = false;  // empty fields: the controller's values, not the defaults
};

// A move the controller acknowledged: what wait() judges it against.
struct StartedMove {
  MoveStart start;
};

// A move checked and its direct data written, its start (D9100) not yet
// sent: Actuator::prepare(), then go(). A cycle's parallel group prepares
// every axis first and then sends the starts back to back, so the axes start
// one transaction apart, not one whole start() apart (issue 34's start skew).
struct PreparedMove {
  MoveGoal goal;
  lec::StatusFlags flags_before;
  lec::StateData state_before;
  bool relative = false;
};

// What fills the fields a move (or a blank step) does not give: the one set
// of defaults of every front end, lec::default_step_data().
lec::StepData default_direct_data();

// The direct data a move writes: its fields over default_direct_data(), or,
// with move.keep, over the controller's current data (when those are valid).
lec::StepData merge_direct(const lec::StepData& current, const DirectMove& move);

// The values of merge_direct() that came from the controller, not from the
// move: "speed 300 mm/s", "in position 20.00 mm"… Empty unless move.keep.
std::vector<std::string> kept_direct_values(const lec::StepData& current, const DirectMove& move);

// Optional limits on a target, per axis (issue 27). The stroke is not in the
// memory map: a target beyond it reaches the controller, which raises alarm
// 62 (direct) or 52 (step). With limits set, start(), run_step() and
// retarget() refuse such a target with InvalidRequest before anything is
// written. INC targets are checked as the previous target + the distance.
struct SoftLimits {
  int32_t min_001mm = 0;
  int32_t max_001mm = 0;
};

// "target 9999.00 mm is beyond the soft limits 0.00 to 400.00 mm of this
// axis: nothing was written"; std::nullopt when within them.
std::optional<std::string> soft_limit_violation(const SoftLimits& limits, int32_t target_001mm);

class Actuator {
 public:
  explicit Actuator(Client& client) : client_(client) {}

  void set_soft_limits(std::optional<SoftLimits> limits) { soft_limits_ = limits; }
  const std::optional<SoftLimits>& soft_limits() const noexcept { return soft_limits_; }

  Client& client() noexcept { return client_; }
  TimePoint deadline_in(Duration d) const { return client_.clock().now() + d; }

  void set_serial_mode(bool serial);
  void servo_on(TimePoint deadline, const WaitOptions& wait = {});
  void servo_off(TimePoint deadline, const WaitOptions& wait = {});
  // SETUP ← 1, wait for the return to origin to end, SETUP ← 0 (always).
  MoveResult home(TimePoint deadline, const WaitOptions& wait = {});
  // IN0–IN5 ← step, DRIVE ← 1, wait for the move to end, DRIVE ← 0 (always).
  MoveResult run_step(unsigned step, TimePoint deadline, const WaitOptions& wait = {});
  // start() then wait().
  MoveResult move(const DirectMove& move, TimePoint deadline, const WaitOptions& wait = {});
  // Checks serial mode, servo and alarms (nothing is written when one
  // fails), writes only the direct-data registers that change, then D9100.
  StartedMove start(const DirectMove& move);
  // start() in two halves: prepare() reads, checks and writes the direct data
  // (nothing moves); go() writes the start. The checks are as old as the
  // prepare() when the start goes: call go() at once (the transactions of the
  // other axes' prepare() at most between).
  PreparedMove prepare(const DirectMove& move);
  StartedMove go(const PreparedMove& prepared);
  // A follower's setpoint (`lec follow`): rewrites only the position (and
  // speed, when given and changed) of the direct data this Actuator last
  // wrote, and starts again with D9100. A running move is retargeted; no
  // checks and no wait, so a stream of setpoints costs two writes each.
  StartedMove retarget(int32_t position_001mm, std::optional<uint16_t> speed_mm_s = std::nullopt);
  // Waits for a started move to end (completion.hpp).
  MoveResult wait(const StartedMove& started, TimePoint deadline, const WaitOptions& wait = {});
  // JOG± ← 1 until `until` or cancel(), then ← 0; waits for the axis to stop.
  MoveResult jog(bool plus, TimePoint until, TimePoint deadline, const WaitOptions& wait = {});
  void hold(bool on);
  // Decelerating stop: a RESET pulse with no alarm active cancels the
  // operation. Nothing is checked afterwards (a RESET another client left at
  // 1 makes it no edge): prefer stop(kind, policy), which watches the axis.
  void stop();
  // A stop judged by the axis (stop.hpp): the edge, then reads until the
  // axis is at rest, escalating by `policy`. Never throws for a line fault:
  // the report says what could not be sent or read.
  StopReport stop(StopKind kind, const StopPolicy& policy);
  // RESET pulse; returns the codes still active afterwards (not resettable).
  std::vector<uint8_t> reset_alarms();
  // The codes of the alarm being generated (history group 0) when ALARM = 1.
  std::vector<uint8_t> active_alarms(const lec::StatusFlags& flags);

 private:
  struct Before {
    lec::ControlFlags controls;
    lec::StatusFlags flags;
    lec::StateData state;
  };
  Before ready_to_move(std::string_view what);
  void check_soft_limits(int32_t target_001mm) const;
  void require_serial_mode(const lec::ControlFlags& controls);
  void pulse(lec::Coil coil);
  bool at_rest(StopKind kind, StopReport& report);
  bool watch(StopKind kind, const StopPolicy& policy, TimePoint until_rest, TimePoint deadline,
             StopReport& report);
  [[noreturn]] void raise_alarm(const lec::StatusFlags& flags, std::string_view during);
  void check_cancel(const WaitOptions& wait);
  void check_deadline(TimePoint deadline, std::string_view what);
  MoveResult poll_until_done(Completion& done, TimePoint started_at, const WaitOptions& wait);
  MoveResult conclude(MoveResult r, std::string_view what);
  [[noreturn]] void stop_after_interrupt(const MoveResult& r);

  Client& client_;
  // The direct data as this Actuator last wrote them, for retarget().
  std::optional<lec::StepData> direct_written_;
  std::optional<SoftLimits> soft_limits_;
};

}  // namespace lec6::client
