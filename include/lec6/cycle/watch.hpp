#pragma once
// Judges one activity of a batch from polls and time points, sans-I/O:
//  - a move or push: client::Completion (the one rule that ends a move),
//    its result mapped to an Outcome (deadline -> timeout);
//  - a wait: the flag or position as asked -> done; past its timeout -> timeout;
//  - a dwell: done at its end (wake_at() says when; no poll needed).
// Attacked by tests/cycle/runner_test.cpp (EveryStepKindOnTheTwin,
// WaitsForAPositionDuringAMove, AWaitPastItsTimeoutAborts) on the twin.
//
// Thread safety: one activity's and one thread's; no references kept
// except to the Step, which must outlive it.

#include <optional>

#include "lec6/client/completion.hpp"
#include "lec6/cycle/cycle.hpp"
#include "lec6/cycle/engine.hpp"

namespace lec6::cycle {

// A move's end as conditions name it (deadline -> timeout).
Outcome outcome_of(client::MoveOutcome o) noexcept;

class Watch {
 public:
  // A started move or push.
  static Watch motion(const Step& step, const client::MoveStart& start, TimePoint deadline);
  // A wait or a dwell begun at `now`.
  static Watch timed(const Step& step, TimePoint now);

  // A poll of the activity's axis (a dwell takes any poll, or none: feed_time).
  std::optional<ActivityResult> feed(const client::Poll& poll);
  std::optional<ActivityResult> feed_time(TimePoint now);
  // A dwell's end; nullopt for the others (they need polls).
  std::optional<TimePoint> wake_at() const;
  // The last MoveResult of a motion (for the report), if any.
  const std::optional<client::MoveResult>& move_result() const noexcept { return move_; }

 private:
  explicit Watch(const Step& step) : step_(&step) {}
  const Step* step_;
  std::optional<client::Completion> completion_;
  std::optional<client::MoveResult> move_;
  TimePoint begun_{};
  TimePoint until_{};
};

}  // namespace lec6::cycle
