// The completion rule (completion.hpp) fed by hand: each case is a sequence
// of polls a real controller can produce, and the one answer that is right.

#include "lec6/client/completion.hpp"

#include <gtest/gtest.h>

#include <vector>

#include "test_time.hpp"

namespace lec6::client {
namespace {

using lec::StatusFlags;

const TimePoint t0 = TimePoint{} + std::chrono::seconds(10);

using testing::ms;

StatusFlags flags(std::initializer_list<StatusFlags::Bit> on, uint8_t out = 0) {
  StatusFlags f;
  f.set(StatusFlags::Svre, true);
  f.set(StatusFlags::Seton, true);
  for (auto b : on) f.set(b, true);
  f.set_out(out);
  return f;
}

lec::StateData state(int32_t pos, int32_t target, uint16_t thrust = 0) {
  lec::StateData s;
  s.position_001mm = pos;
  s.target_001mm = target;
  s.thrust_pct = thrust;
  return s;
}

MoveGoal positioning(int32_t target, int32_t band = 50) {
  MoveGoal g;
  g.target_001mm = target;
  g.in_position_001mm = band;
  return g;
}

MoveGoal pushing(int32_t start, int32_t distance, uint16_t trigger = 40) {
  MoveGoal g;
  g.operation = Operation::Pushing;
  g.target_001mm = start;
  g.pushing_distance_001mm = distance;
  g.trigger_level_pct = trigger;
  return g;
}

// Feeds polls 10 ms apart from t0 + 10 ms; returns the first result and
// the index of the poll that gave it (-1: still running after all).
struct Run {
  std::optional<MoveResult> result;
  int at = -1;
};
Run run(Completion& c, const std::vector<std::pair<StatusFlags, lec::StateData>>& polls,
        Duration step = ms(10)) {
  Run r;
  for (std::size_t i = 0; i < polls.size(); ++i) {
    const TimePoint at = t0 + step * static_cast<int64_t>(i + 1);
    if (auto x = c.feed({polls[i].first, polls[i].second, at})) {
      r.result = x;
      r.at = static_cast<int>(i);
      return r;
    }
  }
  return r;
}

MoveStart from(MoveGoal g, StatusFlags before, lec::StateData was) {
  return MoveStart{g, before, was, false, t0};
}

TEST(Completion, StaleInpOnTheFirstPollIsNotCompletion) {
  // BUSY rises late; INP still holds the previous move's 1 meanwhile.
  Completion c(from(positioning(15000), flags({StatusFlags::Inp}), state(0, 0)), t0 + ms(5000));
  const auto r = run(c, {{flags({StatusFlags::Inp}), state(0, 0)},
                         {flags({StatusFlags::Busy}), state(500, 15000)},
                         {flags({StatusFlags::Busy}), state(9000, 15000)},
                         {flags({StatusFlags::Inp}), state(15000, 15000)}});
  ASSERT_TRUE(r.result);
  EXPECT_EQ(r.at, 3);
  EXPECT_EQ(r.result->outcome, MoveOutcome::Reached);
  EXPECT_EQ(r.result->evidence, "BUSY");
  EXPECT_EQ(r.result->timeline.busy_up, ms(20));
  EXPECT_EQ(r.result->timeline.busy_down, ms(40));
  EXPECT_EQ(r.result->timeline.inp, ms(40));
}

TEST(Completion, PushWithDelayedBusyWaitsForTheContact) {
  // The case that fooled the old wait: no target register to lean on.
  const auto before = flags({StatusFlags::Inp});
  Completion c(from(pushing(30000, 2000), before, state(10000, 10000)), t0 + ms(5000));
  const auto r = run(c, {{before, state(10000, 10000)},
                         {before, state(10000, 10000)},
                         {flags({StatusFlags::Busy}), state(20000, 30000, 20)},
                         {flags({StatusFlags::Inp}), state(30870, 30000, 50)}});
  ASSERT_TRUE(r.result);
  EXPECT_EQ(r.at, 3);
  EXPECT_EQ(r.result->outcome, MoveOutcome::Pushed);
  EXPECT_EQ(r.result->describe(), "pushed: workpiece at 308.70 mm, thrust 50 % (INP) in 0.04 s");
}

TEST(Completion, NoEvidenceEndsAsNotStartedNeverSuccess) {
  const auto before = flags({StatusFlags::Inp});
  Completion c(from(positioning(15000), before, state(0, 0)), t0 + ms(5000));
  std::vector<std::pair<StatusFlags, lec::StateData>> idle(40, {before, state(0, 0)});
  const auto r = run(c, idle);
  ASSERT_TRUE(r.result);
  EXPECT_EQ(r.result->outcome, MoveOutcome::NotStarted);
  EXPECT_FALSE(r.result->succeeded());
  EXPECT_EQ(r.at, 19);  // the 200 ms window, not earlier
  EXPECT_NE(r.result->describe().find("did not start"), std::string::npos);
}

// A move whose whole run fell before the first poll and was stopped short
// (Python's axis.wait() begun after stop()): D9004 holds its target and the
// carriage came toward it; it started and it stopped, it is not "not
// started" (which would send another stop).
TEST(Completion, AMoveStoppedBeforeAnyPollIsStoppedNotNotStarted) {
  const auto before = flags({StatusFlags::Inp});
  Completion c(from(positioning(15000), before, state(0, 0)), t0 + ms(5000));
  std::vector<std::pair<StatusFlags, lec::StateData>> rest(30, {flags({}), state(1156, 15000)});
  const auto r = run(c, rest);
  ASSERT_TRUE(r.result);
  EXPECT_EQ(r.at, 19);  // judged when the start window is over, as rule 3's other case
  EXPECT_EQ(r.result->outcome, MoveOutcome::Stopped);
  EXPECT_EQ(r.result->evidence,
            "D9004 = the target and the carriage moved toward it (BUSY not seen)");
  // Moved, but away from the target, or by less than the tolerance, or with
  // another target in D9004: no evidence that this move ran.
  for (const auto& seen : {state(-500, 15000), state(5, 15000), state(1156, 9000)}) {
    Completion d(from(positioning(15000), before, state(0, 0)), t0 + ms(5000));
    std::vector<std::pair<StatusFlags, lec::StateData>> polls(30, {flags({}), seen});
    EXPECT_EQ(run(d, polls).result->outcome, MoveOutcome::NotStarted) << seen.position_001mm;
  }
  // A carriage still coasting from an earlier stop when the start was given
  // (BUSY falls at a RESET while it decelerates), or still moving now: a
  // start taken late must stay NotStarted, so that it is stopped.
  lec::StateData coasting = state(0, 15000);
  coasting.speed_mm_s = 40;
  lec::StateData rolling = state(1156, 15000);
  rolling.speed_mm_s = 20;
  for (const auto& [was, seen] :
       {std::pair{coasting, state(1156, 15000)}, std::pair{state(0, 0), rolling}}) {
    Completion d(from(positioning(15000), before, was), t0 + ms(5000));
    std::vector<std::pair<StatusFlags, lec::StateData>> polls(30, {flags({}), seen});
    EXPECT_EQ(run(d, polls).result->outcome, MoveOutcome::NotStarted) << was.speed_mm_s;
  }
}

TEST(Completion, PushWithoutAnyEvidenceIsNotStarted) {
  const auto before = flags({StatusFlags::Inp});
  Completion c(from(pushing(30000, 2000), before, state(10000, 10000)), t0 + ms(5000));
  std::vector<std::pair<StatusFlags, lec::StateData>> idle(30, {before, state(10000, 10000)});
  EXPECT_EQ(run(c, idle).result->outcome, MoveOutcome::NotStarted);
}

TEST(Completion, AMissedShortPulseAtTheTargetIsSettledOnlyAfterTheWindow) {
  // Already at 150.00 mm: the ~60 ms BUSY pulse falls between two polls.
  const auto before = flags({StatusFlags::Inp});
  Completion c(from(positioning(15000), before, state(15000, 15000)), t0 + ms(5000));
  std::vector<std::pair<StatusFlags, lec::StateData>> polls(25, {before, state(15000, 15000)});
  const auto r = run(c, polls);
  ASSERT_TRUE(r.result);
  EXPECT_EQ(r.result->outcome, MoveOutcome::Reached);
  EXPECT_EQ(r.at, 19);
  EXPECT_FALSE(r.result->timeline.busy_up);
}

TEST(Completion, AtTheTargetWithoutInpIsNotSettled) {
  const auto before = flags({});
  Completion c(from(positioning(15000), before, state(15000, 15000)), t0 + ms(5000));
  std::vector<std::pair<StatusFlags, lec::StateData>> polls(25, {before, state(15000, 15000)});
  EXPECT_EQ(run(c, polls).result->outcome, MoveOutcome::NotStarted);
}

TEST(Completion, AtTheTargetWithAnotherTargetRegisterIsNotSettled) {
  // In the band with INP from the previous move (to 150.20 mm), asked for
  // 150.00 mm: had the controller taken the start, D9004 would say 150.00.
  const auto before = flags({StatusFlags::Inp});
  Completion c(from(positioning(15000), before, state(15020, 15020)), t0 + ms(5000));
  std::vector<std::pair<StatusFlags, lec::StateData>> polls(25, {before, state(15020, 15020)});
  EXPECT_EQ(run(c, polls).result->outcome, MoveOutcome::NotStarted);
}

TEST(Completion, TheWindowNeedsPollsToo) {
  // Polls 100 ms apart: the window (200 ms) is over at the 2nd, but 3 polls are needed.
  const auto before = flags({StatusFlags::Inp});
  Completion c(from(positioning(15000), before, state(15000, 15000)), t0 + ms(5000));
  std::vector<std::pair<StatusFlags, lec::StateData>> polls(5, {before, state(15000, 15000)});
  const auto r = run(c, polls, ms(100));
  EXPECT_EQ(r.at, 2);
}

TEST(Completion, RetargetDoesNotTakeTheOldBusyAsEvidence) {
  // A start while the old move runs; the old move ends at 100.00 mm during
  // the new start's BUSY delay, then the new move runs to 150.00 mm.
  const auto busy = flags({StatusFlags::Busy});
  Completion c(from(positioning(15000), busy, state(9000, 10000)), t0 + ms(5000));
  const auto r = run(c, {{busy, state(9900, 10000)},
                         {flags({StatusFlags::Inp}), state(10000, 10000)},
                         {busy, state(10100, 15000)},
                         {busy, state(14000, 15000)},
                         {flags({StatusFlags::Inp}), state(15000, 15000)}});
  ASSERT_TRUE(r.result);
  EXPECT_EQ(r.at, 4);
  EXPECT_EQ(r.result->outcome, MoveOutcome::Reached);
  EXPECT_EQ(r.result->evidence, "BUSY rose again");
}

TEST(Completion, RetargetWithContinuousBusyNeedsTheTargetRegister) {
  const auto busy = flags({StatusFlags::Busy});
  Completion c(from(positioning(15000), busy, state(5000, 10000)), t0 + ms(5000));
  std::vector<std::pair<StatusFlags, lec::StateData>> polls(19, {busy, state(8000, 15000)});
  polls.push_back({busy, state(14000, 15000)});  // 200 ms: the window is over
  polls.push_back({flags({StatusFlags::Inp}), state(15000, 15000)});
  const auto r = run(c, polls);
  ASSERT_TRUE(r.result);
  EXPECT_EQ(r.at, 20);
  EXPECT_EQ(r.result->outcome, MoveOutcome::Reached);
}

TEST(Completion, RetargetIgnoredByTheControllerIsNotStarted) {
  const auto busy = flags({StatusFlags::Busy});
  Completion c(from(positioning(15000), busy, state(5000, 10000)), t0 + ms(5000));
  std::vector<std::pair<StatusFlags, lec::StateData>> polls(25, {busy, state(8000, 10000)});
  EXPECT_EQ(run(c, polls).result->outcome, MoveOutcome::NotStarted);
}

TEST(Completion, StepOutputsShowAStartWhoseBusyWasMissed) {
  MoveGoal g = positioning(15000);
  g.step = 3;
  const auto before = flags({StatusFlags::Inp}, 1);
  Completion c(from(g, before, state(10000, 10000)), t0 + ms(5000));
  const auto r =
      run(c, {{before, state(10000, 10000)}, {flags({StatusFlags::Inp}, 3), state(15000, 15000)}});
  ASSERT_TRUE(r.result);
  EXPECT_EQ(r.result->outcome, MoveOutcome::Reached);
  EXPECT_EQ(r.result->evidence, "OUT0-OUT5 = 3");
}

TEST(Completion, HomingFromUnhomedEndsOnSetonRising) {
  MoveGoal g;
  g.operation = Operation::Home;
  StatusFlags before;
  before.set(StatusFlags::Svre, true);
  Completion c(from(g, before, state(0, 0)), t0 + ms(60000));
  const auto r = run(c, {{before, state(0, 0)}, {flags({StatusFlags::Inp}), state(0, 0)}});
  ASSERT_TRUE(r.result);
  EXPECT_EQ(r.result->outcome, MoveOutcome::Reached);
  EXPECT_EQ(r.result->evidence, "SETON rose");
}

TEST(Completion, HomingWhenHomedWaitsForItsPulse) {
  MoveGoal g;
  g.operation = Operation::Home;
  const auto homed = flags({StatusFlags::Inp});
  Completion c(from(g, homed, state(0, 0)), t0 + ms(60000));
  const auto r = run(
      c, {{homed, state(0, 0)}, {flags({StatusFlags::Busy}), state(0, 0)}, {homed, state(0, 0)}});
  ASSERT_TRUE(r.result);
  EXPECT_EQ(r.at, 2);
}

TEST(Completion, PushThatMeetsNothingIsMissed) {
  Completion c(from(pushing(30000, 2000), flags({StatusFlags::Inp}), state(10000, 10000)),
               t0 + ms(5000));
  const auto r = run(
      c, {{flags({StatusFlags::Busy}), state(20000, 30000, 10)}, {flags({}), state(32000, 30000)}});
  EXPECT_EQ(r.result->outcome, MoveOutcome::PushMissed);
  EXPECT_EQ(r.result->describe(),
            "push missed: moved the whole pushing distance (20.00 mm) without contact (INP = 0), "
            "at 320.00 mm");
}

TEST(Completion, BusyFallingShortWithoutAlarmIsStoppedNotReached) {
  Completion c(from(positioning(15000), flags({StatusFlags::Inp}), state(0, 0)), t0 + ms(5000));
  const auto r =
      run(c, {{flags({StatusFlags::Busy}), state(5000, 15000)}, {flags({}), state(12033, 15000)}});
  EXPECT_EQ(r.result->outcome, MoveOutcome::Stopped);
  EXPECT_EQ(r.result->stop_cause, StopCause::Unknown);
  EXPECT_EQ(r.result->describe().substr(0, 48), "stopped at 120.33 mm before the target 150.00 mm");
  StatusFlags off;  // servo off: SVRE 0
  Completion d(from(positioning(15000), flags({StatusFlags::Inp}), state(0, 0)), t0 + ms(5000));
  const auto s = run(d, {{flags({StatusFlags::Busy}), state(5000, 15000)}, {off, state(6000, 0)}});
  EXPECT_EQ(s.result->stop_cause, StopCause::ServoOff);
}

// Digest §5: success is INP = 1 after BUSY fell. INP that rises a few polls
// later at the target is waited for, and its time is the settle time's end.
TEST(Completion, InpRisingAfterBusyFellIsWaitedForAndTimed) {
  Completion c(from(positioning(15000), flags({StatusFlags::Inp}), state(0, 0)), t0 + ms(5000));
  const auto r = run(c, {{flags({StatusFlags::Busy}), state(5000, 15000)},
                         {flags({StatusFlags::Busy}), state(14000, 15000)},
                         {flags({}), state(15000, 15000)},
                         {flags({}), state(15001, 15000)},
                         {flags({StatusFlags::Inp}), state(15000, 15000)}});
  ASSERT_TRUE(r.result);
  EXPECT_EQ(r.at, 4);
  EXPECT_EQ(r.result->outcome, MoveOutcome::Reached);
  EXPECT_EQ(r.result->timeline.busy_down, ms(30));
  EXPECT_EQ(r.result->timeline.busy_down_after, ms(20));
  EXPECT_EQ(r.result->timeline.inp, ms(50));
  EXPECT_EQ(r.result->timeline.inp_after, ms(40));
}

TEST(Completion, AtTheTargetWithoutInpPastTheSettleWindowIsStopped) {
  Completion c(from(positioning(15000), flags({StatusFlags::Inp}), state(0, 0)), t0 + ms(5000));
  std::vector<std::pair<StatusFlags, lec::StateData>> polls{
      {flags({StatusFlags::Busy}), state(5000, 15000)}};
  for (int i = 0; i < 40; ++i) polls.push_back({flags({}), state(15000, 15000)});
  const auto r = run(c, polls);
  ASSERT_TRUE(r.result);
  EXPECT_EQ(r.result->outcome, MoveOutcome::Stopped);
  EXPECT_EQ(r.at, 31) << "judged when the 300 ms settle window is over, not before";
  // Short of the band: judged at BUSY's fall, as before.
  Completion d(from(positioning(15000), flags({StatusFlags::Inp}), state(0, 0)), t0 + ms(5000));
  const auto s =
      run(d, {{flags({StatusFlags::Busy}), state(5000, 15000)}, {flags({}), state(12033, 15000)}});
  EXPECT_EQ(s.at, 1);
}

TEST(Completion, AlarmEndsAtOnceAndDeadlineAfterIt) {
  Completion c(from(positioning(15000), flags({}), state(0, 0)), t0 + ms(5000));
  EXPECT_EQ(run(c, {{flags({StatusFlags::Alarm}), state(0, 0)}}).result->outcome,
            MoveOutcome::Alarm);
  Completion d(from(positioning(15000), flags({}), state(0, 0)), t0 + ms(35));
  const auto r = run(d, std::vector<std::pair<StatusFlags, lec::StateData>>(
                            10, {flags({StatusFlags::Busy}), state(10, 15000)}));
  EXPECT_EQ(r.result->outcome, MoveOutcome::Deadline);
  EXPECT_EQ(r.at, 3);  // the first poll past the deadline
}

TEST(Completion, InterruptedReportsTheLastPoll) {
  Completion c(from(positioning(15000), flags({}), state(0, 0)), t0 + ms(5000));
  run(c, {{flags({StatusFlags::Busy}), state(4242, 15000)}});
  const auto r = c.interrupted();
  EXPECT_EQ(r.outcome, MoveOutcome::Stopped);
  EXPECT_EQ(r.stop_cause, StopCause::Interrupted);
  EXPECT_EQ(r.state.position_001mm, 4242);
}

}  // namespace
}  // namespace lec6::client
