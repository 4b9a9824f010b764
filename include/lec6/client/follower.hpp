#pragma once
// An axis as a follower (issue 12): joysticks, vision systems and ROS send
// a new position many times a second. Each setpoint is a retarget of the
// running direct operation — two writes (the position, D9104–D9105, and
// the start, D9100; D9101 refuses writes, so they cannot be one FC10) — and
// every `check_every`-th setpoint the flags and the control coils are read,
// so an alarm, a servo that went off, or a HOLD or RESET another master set
// (issue 31 rule 6: a stop ends what moves) stops the follower within a few
// setpoints (tests/client/follower_test.cpp).
//
//   Follower f(axis, {.move = {.speed_mm_s = 200}});
//   while (auto p = newest_setpoint()) f.apply(*p);   // drop stale ones yourself
//   auto r = f.finish(axis.deadline_in(seconds(30)));  // wait for the last one
//
// Thread safety and lifetime: one thread at a time. A Follower keeps a
// reference to its Actuator (which keeps one to its Client), so both must
// outlive it; nothing else may use that Client while the Follower follows
// (a SharedMaster lets other threads share the line through Clients of their own).

#include <cstdint>
#include <optional>

#include "lec6/client/actuator.hpp"

namespace lec6::client {

struct FollowOptions {
  // Speed, accelerations, in-position width of every setpoint (the first
  // setpoint writes them; position is ignored here).
  DirectMove move;
  unsigned check_every = 8;  // read the flags and the control coils after this many setpoints
};

class Follower {
 public:
  Follower(Actuator& axis, FollowOptions options);

  // Sends one setpoint (ABS, 0.01 mm) now. The first one checks serial
  // mode, servo and homing like Actuator::start. Throws AlarmError when a
  // flags check finds an alarm; servo_lost() tells when SVRE fell.
  void apply(int32_t position_001mm);
  // Reads the flags and state (while there is no new setpoint) and checks
  // them as apply() does.
  lec::StatusFlags check();
  // Waits for the last setpoint's move to end; nullopt when none was applied.
  std::optional<MoveResult> finish(TimePoint deadline, const WaitOptions& wait = {});

  uint64_t applied() const noexcept { return applied_; }
  uint64_t checks() const noexcept { return checks_; }
  const lec::StatusFlags& last_flags() const noexcept { return flags_; }
  // The last flags read show the servo off (SVRE = 0 or ESTOP): following
  // cannot go on.
  bool servo_lost() const noexcept { return checks_ > 0 && (!flags_.svre() || flags_.estop()); }
  // The last control coils read show HOLD or RESET at 1: another master (an
  // HMI, lec serve) holds or stops the axis. Following must not go on (each
  // setpoint is a start); nothing is written to undo it.
  bool stopped_elsewhere() const noexcept {
    return checks_ > 0 && (controls_.test(lec::Coil::HOLD) || controls_.test(lec::Coil::RESET));
  }
  const lec::ControlFlags& last_controls() const noexcept { return controls_; }
  const lec::StateData& last_state() const noexcept { return state_; }

 private:
  void judge(const lec::StatusFlags& flags);

  Actuator& axis_;
  FollowOptions options_;
  std::optional<StartedMove> last_;
  unsigned since_check_ = 0;
  uint64_t applied_ = 0;
  uint64_t checks_ = 0;
  void look();  // reads the flags and the control coils, and judges them
  lec::StatusFlags flags_;
  lec::ControlFlags controls_;
  lec::StateData state_;
};

}  // namespace lec6::client
