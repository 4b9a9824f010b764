#pragma once
// The one rule that ends a move (issue 12), sans-I/O: fed polls (flags read
// first, then state, and the time), it answers "running" or the MoveResult.
//
//   Completion done(start, deadline);
//   for (;;) {
//     auto flags = client.read_flags();  auto at = clock.now();
//     auto state = client.read_state();
//     if (auto r = done.feed({flags, state, at})) return *r;
//   }
//
// It decides from evidence, never from one sample, because a real
// controller can raise BUSY milliseconds after it acknowledged the start,
// keep INP from the previous move until then, and show only a ~60 ms BUSY
// pulse for a move that is already at its target.
//
// 1. The move has *started* (this start, not the previous move) once a poll
//    shows one of:
//    - BUSY = 1, when BUSY was 0 before the start;
//    - a fresh BUSY edge (0 then 1) after a start given while BUSY was 1
//      (a retarget), or, once the start window is over, BUSY = 1 with D9004
//      holding the new target (the pending start has begun by then);
//    - OUT0–OUT5 = the step number, when they held another number before
//      (the outputs change when BUSY rises);
//    - homing: SETON rising;
//    - pushing: contact that the previous move cannot have left behind (BUSY
//      0, INP 1, thrust ≥ trigger level, when it was not so before), or the
//      carriage at the end of the pushing distance with INP 0 (a miss), when
//      it was not there before.
// 2. A started move ends when BUSY is 0; the outcome is then read from INP,
//    the position against the goal, thrust, SETON, SVRE and ESTOP. "Success
//    is INP = 1 after that" (digest §5): a positioning move or homing whose
//    BUSY fell at its target, within its band, with INP still 0 is polled
//    on for up to the settle window (default 300 ms) until INP rises, so the
//    settle time (BUSY's fall to INP) is measured, not taken as 0
//    (completion_test.cpp InpRisingAfterBusyFellIsWaitedForAndTimed).
// 3. When the start window (default 200 ms and at least 3 polls) is over
//    with no such evidence and BUSY 0, the move counts as done only when the
//    axis is demonstrably where it was sent: INP = 1, D9004 = the target,
//    the position within the in-position band (homing: SETON, INP, at the
//    origin). That settles a BUSY pulse that fell between two polls of a
//    move already at its target. A positioning move whose whole run fell
//    between two polls and was stopped short (a wait begun late:
//    Python's axis.wait() after stop()) shows as D9004 = the target and
//    the carriage, at rest at the start and at rest now, moved toward it by
//    more than the position tolerance: it started, and it ended Stopped
//    (a carriage still coasting at either end is no evidence; completion_test.cpp
//    AMoveStoppedBeforeAnyPollIsStoppedNotNotStarted). Otherwise: NotStarted,
//    never success.
// 4. An alarm ends the move at once; past the deadline, Deadline.
//
// The start window must exceed the controller's BUSY delay plus its
// shortest BUSY pulse (the field profile: 20 + 60 ms).
//
// Thread safety: a Completion is one move's and one thread's; it does no I/O
// and keeps no references (the MoveStart and the polls are copied in), so it
// may outlive the Client that fed it. The free functions are pure.

#include <optional>

#include "lec6/client/move_result.hpp"
#include "lec6/clock.hpp"
#include "lec6/lec/flags.hpp"
#include "lec6/lec/state_data.hpp"

namespace lec6::client {

struct CompletionOptions {
  Duration start_window = std::chrono::milliseconds(200);
  unsigned start_window_polls = 3;
  Duration settle_window = std::chrono::milliseconds(300);  // rule 2: INP after BUSY fell
};

// Positions closer than this are "at" the origin or the end of a push
// (0.10 mm: two encoder counts either way on the LEC actuators' 0.01 mm scale).
inline constexpr int32_t kPositionTolerance001mm = 10;

struct Poll {
  lec::StatusFlags flags;
  lec::StateData state;
  TimePoint at;  // when the flags were read: their reply's last byte on the wire
  // When the flags' query was written (issue 32); {}: at. The controller
  // sampled the flags between the two, so an edge this poll saw happened
  // after the previous poll's `sent_at` and before this one's `at`.
  TimePoint sent_at{};
};

// The context of one start.
struct MoveStart {
  MoveGoal goal;
  lec::StatusFlags flags_before;  // read before the start
  lec::StateData state_before;
  // A move may be running although flags_before does not say so (they are
  // older than the start: `lec follow` reads flags only now and then).
  bool may_be_running = false;
  TimePoint at;  // the start was acknowledged (its reply's last byte on the wire)
  // When the start's request was written; {}: at. BUSY may rise before the
  // start's reply ends: its bracket opens here.
  TimePoint sent_at{};
};

class Completion {
 public:
  Completion(MoveStart start, TimePoint deadline, CompletionOptions options = {});

  // One poll; nullopt while the move runs. After a result, do not feed again.
  std::optional<MoveResult> feed(const Poll& poll);

  // The result to report when the caller stopped the axis itself (Ctrl-C).
  MoveResult interrupted() const;

  bool started() const noexcept { return started_; }
  const MoveTimeline& timeline() const noexcept { return timeline_; }

 private:
  bool retarget() const noexcept;
  void look_for_start(const Poll& p, Duration t);
  void mark_started(const Poll& p, Duration t, std::string evidence);
  bool settled_without_busy(const Poll& p) const;
  bool moved_toward_target(const Poll& p) const;
  bool settling(const Poll& p, Duration t) const;
  MoveOutcome judge(const Poll& p) const;
  int32_t push_end() const;
  MoveResult result(MoveOutcome o, const Poll& p) const;

  MoveStart start_;
  TimePoint deadline_;
  CompletionOptions options_;
  unsigned polls_ = 0;
  bool started_ = false;
  bool saw_busy_low_ = false;
  std::string evidence_;
  MoveTimeline timeline_;
  std::optional<Poll> last_;
  // Where the next edge's bracket opens, from the start: the previous poll's
  // query (before any poll: the start's, ≤ 0).
  Duration poll_before_{};
};

}  // namespace lec6::client
