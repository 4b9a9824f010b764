// The rule that ends a move: see completion.hpp.

#include "lec6/client/completion.hpp"

#include <fmt/format.h>

#include <cstdlib>

namespace lec6::client {
namespace {

bool within(int64_t position, int64_t target, int64_t band) {
  return std::llabs(position - target) <= band;
}

// Where a poll's bracket opens: its query's first byte on the wire.
TimePoint sent_of(const Poll& p) {
  return p.sent_at != TimePoint{} && p.sent_at < p.at ? p.sent_at : p.at;
}

StopCause cause_of(const lec::StatusFlags& f) {
  if (f.estop()) return StopCause::EmergencyStop;
  if (!f.svre()) return StopCause::ServoOff;
  return StopCause::Unknown;
}

}  // namespace

Completion::Completion(MoveStart start, TimePoint deadline, CompletionOptions options)
    : start_(std::move(start)), deadline_(deadline), options_(options) {
  timeline_.origin = start_.at;
  if (start_.sent_at != TimePoint{} && start_.sent_at < start_.at)
    poll_before_ = start_.sent_at - start_.at;
}

bool Completion::retarget() const noexcept {
  return start_.flags_before.busy() || start_.may_be_running;
}

// Where a push ends when it meets nothing: the pushing distance beyond the
// pushing start, in the direction of the approach (+ when the carriage stood
// on the start), as the controller plans it (digest §6).
int32_t Completion::push_end() const {
  const int64_t from = start_.state_before.position_001mm;
  const int64_t start = start_.goal.target_001mm;
  const int64_t dir = start < from ? -1 : 1;
  return static_cast<int32_t>(start + dir * start_.goal.pushing_distance_001mm);
}

void Completion::mark_started(const Poll& p, Duration t, std::string evidence) {
  if (started_) return;
  started_ = true;
  evidence_ = std::move(evidence);
  if (p.flags.busy()) timeline_.busy_up = t, timeline_.busy_up_after = poll_before_;
}

void Completion::look_for_start(const Poll& p, Duration t) {
  const MoveGoal& g = start_.goal;
  const lec::StatusFlags& before = start_.flags_before;
  if (p.flags.busy()) {
    if (!retarget()) mark_started(p, t, "BUSY");
    if (retarget() && saw_busy_low_) mark_started(p, t, "BUSY rose again");
  } else {
    saw_busy_low_ = true;
  }
  if (g.step && before.out() != *g.step && p.flags.out() == *g.step)
    mark_started(p, t, fmt::format("OUT0-OUT5 = {}", *g.step));
  if (g.operation == Operation::Home && !before.seton() && p.flags.seton())
    mark_started(p, t, "SETON rose");
  if (g.operation == Operation::Pushing && !p.flags.busy()) {
    const lec::StateData& was = start_.state_before;
    const bool pressing_before = before.inp() && was.thrust_pct >= g.trigger_level_pct;
    if (p.flags.inp() && p.state.thrust_pct >= g.trigger_level_pct && !pressing_before)
      mark_started(p, t, "contact: thrust at the trigger level");
    const int32_t end = push_end();
    if (!p.flags.inp() && within(p.state.position_001mm, end, kPositionTolerance001mm) &&
        !within(was.position_001mm, end, kPositionTolerance001mm))
      mark_started(p, t, "the whole pushing distance moved");
  }
}

// Rule 3 of the header: the axis is demonstrably where it was sent.
bool Completion::settled_without_busy(const Poll& p) const {
  const MoveGoal& g = start_.goal;
  const lec::StateData& s = p.state;
  switch (g.operation) {
    case Operation::Positioning:
      return p.flags.inp() && s.target_001mm == g.target_001mm &&
             within(s.position_001mm, g.target_001mm, g.in_position_001mm);
    case Operation::Home:
      return p.flags.seton() && p.flags.inp() && s.target_001mm == 0 &&
             within(s.position_001mm, 0, kPositionTolerance001mm);
    case Operation::Pushing:  // only contact or a miss shows a push that was not seen
    case Operation::Jog:
      break;
  }
  return false;
}

// Rule 3's stopped short: the controller holds this move's target (D9004),
// the carriage was at rest at the start and is at rest now, and it has come
// toward the target by more than the position tolerance, with BUSY never
// seen (a start given while BUSY is not judged so: the previous move may
// have carried it).
bool Completion::moved_toward_target(const Poll& p) const {
  const MoveGoal& g = start_.goal;
  if (g.operation != Operation::Positioning || retarget()) return false;
  // At rest at the start and now: motion seen between them came after this
  // start. A carriage still coasting from an earlier stop (BUSY falls at a
  // RESET while it decelerates) is no evidence, and a start the controller
  // takes late must stay NotStarted, so that it is stopped (a reviewer's case).
  if (start_.state_before.speed_mm_s != 0 || p.state.speed_mm_s != 0) return false;
  if (p.state.target_001mm != g.target_001mm) return false;
  const int64_t from = start_.state_before.position_001mm;
  const int64_t to = g.target_001mm;
  const int64_t now = p.state.position_001mm;
  const int64_t dir = to >= from ? 1 : -1;
  return (now - from) * dir > kPositionTolerance001mm &&
         (to - now) * dir >= -kPositionTolerance001mm;
}

// Rule 2's INP after BUSY fell: a positioning move or homing whose BUSY fell
// at its target, within its band, with INP not up yet, is given the settle
// window for INP to rise before it is judged.
bool Completion::settling(const Poll& p, Duration t) const {
  const MoveGoal& g = start_.goal;
  if (p.flags.inp() || p.flags.alarm() || !timeline_.busy_down) return false;
  if (t - *timeline_.busy_down >= options_.settle_window) return false;
  const lec::StateData& s = p.state;
  switch (g.operation) {
    case Operation::Positioning:
      return s.target_001mm == g.target_001mm &&
             within(s.position_001mm, g.target_001mm, g.in_position_001mm);
    case Operation::Home:
      return p.flags.seton() && within(s.position_001mm, 0, kPositionTolerance001mm);
    case Operation::Pushing:  // a push's INP is its contact: judged at BUSY's fall
    case Operation::Jog:
      break;
  }
  return false;
}

// A started move whose BUSY fell: what it did.
MoveOutcome Completion::judge(const Poll& p) const {
  const MoveGoal& g = start_.goal;
  const int32_t pos = p.state.position_001mm;
  switch (g.operation) {
    case Operation::Positioning:
      return p.flags.inp() && within(pos, g.target_001mm, g.in_position_001mm)
                 ? MoveOutcome::Reached
                 : MoveOutcome::Stopped;
    case Operation::Home:
      return p.flags.seton() && within(pos, 0, kPositionTolerance001mm) ? MoveOutcome::Reached
                                                                        : MoveOutcome::Stopped;
    case Operation::Pushing:
      if (p.flags.inp()) return MoveOutcome::Pushed;
      return within(pos, push_end(), kPositionTolerance001mm) ? MoveOutcome::PushMissed
                                                              : MoveOutcome::Stopped;
    case Operation::Jog:
      break;
  }
  return MoveOutcome::Stopped;
}

MoveResult Completion::result(MoveOutcome o, const Poll& p) const {
  MoveResult r;
  r.outcome = o;
  r.goal = start_.goal;
  r.in_position = p.flags.inp();
  r.state = p.state;
  r.flags = p.flags;
  r.started_at = start_.at;
  r.elapsed = p.at - start_.at;
  r.timeline = timeline_;
  if (o != MoveOutcome::Deadline && o != MoveOutcome::Alarm && !p.flags.busy()) {
    if (timeline_.busy_up && !r.timeline.busy_down) {
      r.timeline.busy_down = r.elapsed;
      r.timeline.busy_down_after = poll_before_;
    }
    if (p.flags.inp() && !r.timeline.inp) {
      r.timeline.inp = r.elapsed;
      r.timeline.inp_after = poll_before_;
    }
  }
  r.evidence = evidence_;
  if (o == MoveOutcome::Stopped) {
    r.stop_cause =
        start_.goal.operation == Operation::Jog ? StopCause::Released : cause_of(p.flags);
  }
  return r;
}

std::optional<MoveResult> Completion::feed(const Poll& p) {
  ++polls_;
  if (last_) poll_before_ = sent_of(*last_) - start_.at;
  last_ = p;
  const Duration t = p.at - start_.at;
  if (started_ && !p.flags.busy() && timeline_.busy_up && !timeline_.busy_down)
    timeline_.busy_down = t, timeline_.busy_down_after = poll_before_;
  if (started_ && !p.flags.busy() && p.flags.inp() && !timeline_.inp)
    timeline_.inp = t, timeline_.inp_after = poll_before_;
  if (p.flags.alarm()) return result(MoveOutcome::Alarm, p);

  if (start_.goal.operation == Operation::Jog) {
    // Released: done when the carriage is at rest and BUSY is down.
    if (!p.flags.busy() && p.state.speed_mm_s == 0) return result(MoveOutcome::Stopped, p);
  } else {
    look_for_start(p, t);
    if (started_ && !p.flags.busy() && !settling(p, t)) return result(judge(p), p);
    const bool window_over = t >= options_.start_window && polls_ >= options_.start_window_polls;
    if (!started_ && window_over) {
      if (!p.flags.busy() && settled_without_busy(p)) {
        evidence_ = "at the target with INP = 1 and D9004 = the target (BUSY not seen)";
        return result(MoveOutcome::Reached, p);
      }
      if (!p.flags.busy() && moved_toward_target(p)) {
        evidence_ = "D9004 = the target and the carriage moved toward it (BUSY not seen)";
        started_ = true;
        return result(judge(p), p);
      }
      // A start given while BUSY: by now the new move has begun, and D9004 says so.
      if (retarget() && p.flags.busy() && p.state.target_001mm == start_.goal.target_001mm) {
        mark_started(p, t, "BUSY with D9004 = the new target after the start window");
      } else {
        return result(MoveOutcome::NotStarted, p);
      }
    }
  }
  if (p.at > deadline_) return result(MoveOutcome::Deadline, p);
  return std::nullopt;
}

MoveResult Completion::interrupted() const {
  Poll p = last_.value_or(Poll{start_.flags_before, start_.state_before, start_.at});
  MoveResult r = result(MoveOutcome::Stopped, p);
  r.stop_cause = StopCause::Interrupted;
  return r;
}

}  // namespace lec6::client
