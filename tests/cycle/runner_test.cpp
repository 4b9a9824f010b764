// Cycles on the in-process twin, on a virtual clock: each step kind, a
// branch on a push miss, an interlock refusing (nothing moves), an alarm
// aborting, and a stop during a parallel group (every axis stops, the report
// says where each stood).

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "cell_fixture.hpp"
#include "lec6/lec/step_defaults.hpp"

namespace lec6::cycle {
namespace {

using testing::Cell;
using ::testing::HasSubstr;
using namespace std::chrono_literals;

const std::string kRunAxes = R"(axes:
  x: {id: 1, soft_limits: [0, 400], points: {pick: 300}}
  z: {id: 2, points: {up: 0, clear: 50}, twin: {workpiece_mm: 85}}
)";

const AxisSpan& span(const CycleReport& r, std::size_t step, std::size_t i = 0) {
  return r.steps.at(step).axes.at(i);
}

TEST(Runner, EveryStepKindOnTheTwin) {
  Cell cell(kRunAxes + R"(steps:
  - parallel:
      - move: {axis: x, to: pick, speed: 200}
      - move: {axis: z, to: clear}
  - wait: {axis: z, flag: INP, timeout: 1s}
  - push: {axis: z, to: 80, force: 40, distance: 10}
  - dwell: 500ms
)");
  const CycleReport r = cell.run();
  ASSERT_TRUE(r.completed) << r.ended;
  ASSERT_EQ(r.steps.size(), 4u);
  EXPECT_EQ(span(r, 0, 0).outcome, Outcome::Reached);
  EXPECT_EQ(span(r, 0, 0).position_001mm / 100, 300);
  EXPECT_EQ(span(r, 0, 1).outcome, Outcome::Reached);
  EXPECT_EQ(span(r, 1).outcome, Outcome::Done);
  EXPECT_EQ(span(r, 2).outcome, Outcome::Pushed) << span(r, 2).detail;
  EXPECT_NEAR(cell.position_001mm("z"), 8500, 50);  // against the workpiece
  const Duration dwell = span(r, 3).end - span(r, 3).start;
  EXPECT_GE(dwell, 500ms);
  EXPECT_LT(dwell, 520ms);
  EXPECT_EQ(r.iterations, 1u);
  EXPECT_GE(r.cycle_time, r.steps.back().end);
}

TEST(Runner, AParallelGroupMovesItsAxesTogether) {
  Cell cell(kRunAxes + R"(steps:
  - parallel:
      - move: {axis: x, to: 300, speed: 200}
      - move: {axis: z, to: 80, speed: 50}
)");
  const CycleReport r = cell.run();
  ASSERT_TRUE(r.completed) << r.ended;
  const AxisSpan& x = span(r, 0, 0);
  const AxisSpan& z = span(r, 0, 1);
  // Both prepared first (checks and direct data), then the two starts back
  // to back: one start transaction apart (FC10 to D9100 at 38400 baud:
  // ~9 ms on the wire, Ts and the reply), not one whole start() (~110 ms).
  const Duration one_start = 25ms;
  EXPECT_GT(z.start, x.start);
  EXPECT_LE(z.start - x.start, one_start)
      << "skew " << to_seconds(z.start - x.start) * 1000 << " ms";
  const Duration x_motion = x.end - x.start;
  EXPECT_GT(x_motion, 1400ms);  // 300 mm at 200 mm/s
  const Duration z_motion = z.end - z.start;
  EXPECT_GT(z_motion, 1500ms);  // 80 mm at 50 mm/s
  // The group lasts its preparing, its longest member and a poll round, not
  // the sum of both motions.
  EXPECT_LT(r.steps[0].end - r.steps[0].start,
            (x.start - r.steps[0].start) + std::max(x_motion, z_motion) + 200ms);
}

TEST(Runner, APushMissRunsItsBranch) {
  Cell cell(R"(axes:
  x: {id: 1}
  z: {id: 2}
steps:
  - push: {axis: z, to: 80, force: 40, distance: 10, on_miss: reject}
  - move: {axis: x, to: 20}
branches:
  reject:
    - move: {axis: z, to: 0}
)");
  const CycleReport r = cell.run();
  ASSERT_TRUE(r.completed) << r.ended;
  ASSERT_EQ(r.steps.size(), 3u);
  EXPECT_EQ(span(r, 0).outcome, Outcome::PushMissed);
  EXPECT_EQ(r.steps[0].decision, "branch reject");
  EXPECT_EQ(r.steps[1].path, "reject.1");
  EXPECT_EQ(r.steps[2].path, "2");
  EXPECT_NEAR(cell.position_001mm("z"), 0, 50);
  EXPECT_NEAR(cell.position_001mm("x"), 2000, 50);
}

TEST(Runner, APushMissWithoutABranchAbortsAndStopsEveryAxis) {
  Cell cell(R"(axes:
  x: {id: 1}
  z: {id: 2}
steps:
  - push: {axis: z, to: 80, force: 40, distance: 10}
  - move: {axis: x, to: 20}
)");
  const CycleReport r = cell.run();
  EXPECT_FALSE(r.completed);
  EXPECT_THAT(r.ended, HasSubstr("aborted at step 1 (push z to 80.00 mm): push_missed"));
  EXPECT_EQ(r.steps.size(), 1u);
  ASSERT_EQ(r.stood.size(), 2u);
  EXPECT_NEAR(cell.position_001mm("x"), 0, 50);  // x never moved
}

TEST(Runner, RunsAStoredStep) {
  Cell cell(kRunAxes + "steps:\n  - run_step: {axis: x, step: 3}\n");
  lec::StepData step = lec::default_step_data();
  step.movement_mode = lec::MovementMode::Absolute;
  step.position_001mm = 12345;
  cell.clients.at("x")->write_step(3, step);
  const CycleReport r = cell.run();
  ASSERT_TRUE(r.completed) << r.ended;
  EXPECT_EQ(span(r, 0).outcome, Outcome::Reached);
  EXPECT_NEAR(cell.position_001mm("x"), 12345, 50);
}

TEST(Runner, WaitsForAPositionDuringAMove) {
  Cell cell(kRunAxes + R"(steps:
  - parallel:
      - move: {axis: x, to: 300, speed: 100}
      - wait: {axis: x, above_mm: 150, timeout: 10s}
)");
  const CycleReport r = cell.run();
  ASSERT_TRUE(r.completed) << r.ended;
  EXPECT_EQ(span(r, 0, 1).outcome, Outcome::Done);
  EXPECT_GT(span(r, 0, 1).position_001mm, 15000);
  // Seen within a poll round: the move and the wait share one read of x per
  // round (flags + state, ~25 ms: 2.5 mm at 100 mm/s).
  EXPECT_LT(span(r, 0, 1).position_001mm, 15300);
  EXPECT_LT(span(r, 0, 1).end, span(r, 0, 0).end - 1s);
}

TEST(Runner, AWaitPastItsTimeoutAborts) {
  Cell cell(kRunAxes + "steps:\n  - wait: {axis: z, flag: INP, value: false, timeout: 500ms}\n");
  const CycleReport r = cell.run();
  EXPECT_FALSE(r.completed);
  EXPECT_EQ(span(r, 0).outcome, Outcome::Timeout);
  EXPECT_GE(span(r, 0).end - span(r, 0).start, 500ms);
  EXPECT_THAT(r.ended, HasSubstr("timeout: not met within 0.500 s"));
}

TEST(Runner, AnInterlockRefusesAndNothingMoves) {
  Cell cell(kRunAxes + R"(interlocks:
  - {before_moving: x, axis: z, above_mm: 50}
steps:
  - move: {axis: x, to: pick}
)");
  const auto sent_before = cell.master->stats().transactions;
  const CycleReport r = cell.run();
  EXPECT_FALSE(r.completed);
  EXPECT_THAT(r.ended,
              HasSubstr("interlock: z above 50.00 mm before x moves (axis z is at 0.00 mm)"));
  EXPECT_TRUE(r.steps.empty());
  EXPECT_EQ(cell.position_001mm("x"), 0);
  // Only the reads of the interlock check (flags and state of both axes) and the read above.
  EXPECT_EQ(cell.master->stats().transactions - sent_before, 5u);
}

// The reads before a step are what its decision judges (Engine::next_needs):
// before a dwell the flags of every axis (one transaction each, not two), at
// the cycle's end nothing. Two axes.
TEST(Runner, ADwellReadsTheFlagsAndTheCyclesEndNothing) {
  Cell moves(kRunAxes + "steps:\n  - move: {axis: x, to: 100}\n");
  Cell with_dwells(kRunAxes + R"(steps:
  - move: {axis: x, to: 100}
  - dwell: 200ms
  - dwell: 100ms
)");
  const auto sent = [](Cell& cell) {
    const auto before = cell.master->stats().transactions;
    const CycleReport r = cell.run();
    EXPECT_TRUE(r.completed) << r.ended;
    return cell.master->stats().transactions - before;
  };
  const auto one_move = sent(moves);
  EXPECT_EQ(sent(with_dwells), one_move + 2 * 2);  // each dwell: the flags of both axes
  // A move after the dwell is read for in full again: flags and state of both axes.
  Cell move_after(kRunAxes + R"(steps:
  - move: {axis: x, to: 100}
  - dwell: 200ms
  - move: {axis: x, to: 0}
)");
  EXPECT_GT(sent(move_after), one_move + 2 + 4);
}

// At a moment of the step at `path`, `f` once.
RunOptions at_step(const std::string& path, StepMoment moment, std::function<void()> f) {
  RunOptions o;
  auto done = std::make_shared<bool>(false);
  o.at_step = [=](const Step&, const std::string& p, StepMoment m) {
    if (!*done && p == path && m == moment) {
      *done = true;
      f();
    }
  };
  return o;
}

// A dwell runs only when every axis answers with no alarm and no ESTOP, read
// afresh: an axis the step before did not poll (z in ESTOP while x moved), an
// alarm after the moved axis's last poll, an axis that fell silent.
TEST(Runner, ADwellIsRefusedOnAFreshReadOfEveryAxissFlags) {
  const std::string cycle = kRunAxes + "steps:\n  - move: {axis: x, to: 300}\n  - dwell: 200ms\n";
  Cell estop(cycle);
  CycleReport r = estop.run(at_step(
      "1", StepMoment::Started, [&] { estop.bus.find(2)->set_estop(true, estop.clock.now()); }));
  EXPECT_FALSE(r.completed);
  EXPECT_THAT(r.ended, HasSubstr("refused before step 2 (dwell 0.200 s): interlock: axis z is in "
                                 "emergency stop"));
  Cell alarm(cycle);
  r = alarm.run(at_step("1", StepMoment::Ended,
                        [&] { alarm.bus.find(1)->inject_alarm(149, alarm.clock.now()); }));
  EXPECT_FALSE(r.completed);
  EXPECT_THAT(r.ended, HasSubstr("axis x has an alarm"));
  Cell silent(cycle);
  r = silent.run(at_step("1", StepMoment::Started, [&] { silent.bus.set_cut_off(2, true); }));
  EXPECT_FALSE(r.completed);
  EXPECT_THAT(r.ended, HasSubstr("axis z does not answer"));
}

// The interlock before a group after a dwell is judged on a fresh read of
// the positions: z raised by another master during the dwell refuses x's move.
TEST(Runner, AGroupAfterADwellIsCheckedOnAFreshRead) {
  Cell cell(R"(axes:
  x: {id: 1, soft_limits: [0, 400]}
  z: {id: 2}
interlocks:
  - {before_moving: x, axis: z, below_mm: 45}
steps:
  - move: {axis: z, to: 10}
  - dwell: 200ms
  - parallel: [{move: {axis: x, to: 300}}, {wait: {axis: z, below_mm: 45, timeout: 1s}}]
)");
  const CycleReport r = cell.run(at_step("2", StepMoment::Started, [&] {
    client::Actuator z(*cell.clients.at("z"));
    client::DirectMove up;
    up.position_001mm = 6000;
    z.move(up, z.deadline_in(5s));
  }));
  EXPECT_FALSE(r.completed);
  EXPECT_THAT(r.ended, HasSubstr("refused before step 3"));
  EXPECT_EQ(cell.position_001mm("x"), 0) << "x moved with z at 60 mm";
}

TEST(Runner, AnAxisNotHomedRefusesTheCycle) {
  Cell cell(kRunAxes + "steps:\n  - move: {axis: x, to: pick}\n", /*prepare=*/false);
  const CycleReport r = cell.run();
  EXPECT_FALSE(r.completed);
  EXPECT_THAT(r.ended, HasSubstr("refused before step 1"));
  EXPECT_THAT(r.ended, HasSubstr("is not servo ready"));
}

TEST(Runner, AnAlarmAbortsAndTheReportNamesIt) {
  Cell cell(R"(axes:
  x: {id: 1}
  z: {id: 2}
steps:
  - parallel:
      - move: {axis: z, to: 300, speed: 100}
      - move: {axis: x, to: 450}
)");
  const CycleReport r = cell.run();
  EXPECT_FALSE(r.completed);
  EXPECT_THAT(r.ended, HasSubstr("move x to 450.00 mm): alarm"));
  ASSERT_EQ(r.stood.size(), 2u);
  // z was stopped on its way, well short of 300 mm.
  EXPECT_LT(cell.position_001mm("z"), 20000);
  EXPECT_EQ(span(r, 0, 0).outcome, Outcome::Stopped);
}

TEST(Runner, AStopDuringAParallelGroupStopsEveryAxis) {
  Cell cell(kRunAxes + R"(steps:
  - parallel:
      - move: {axis: x, to: 300, speed: 100}
      - move: {axis: z, to: 200, speed: 100}
  - move: {axis: x, to: 0}
)");
  const TimePoint stop_at = cell.clock.now() + 800ms;
  RunOptions o;
  o.stop_requested = [&] { return cell.clock.now() >= stop_at; };
  const CycleReport r = cell.run(o);
  EXPECT_FALSE(r.completed);
  EXPECT_THAT(r.ended, HasSubstr("stopped by request during step 1 (parallel: "));
  ASSERT_EQ(r.steps.size(), 1u);
  EXPECT_EQ(r.steps[0].decision, "stopped");
  ASSERT_EQ(r.stood.size(), 2u);
  for (const auto& s : r.stood) {
    EXPECT_TRUE(s.stopped) << s.axis << ": " << s.how;
    EXPECT_GT(s.position_001mm, 2000) << s.axis;
    EXPECT_LT(s.position_001mm, 15000) << s.axis;
    EXPECT_EQ(cell.position_001mm(s.axis), s.position_001mm) << s.axis;
  }
  EXPECT_EQ(span(r, 0, 0).outcome, Outcome::Stopped);
  EXPECT_EQ(span(r, 0, 1).outcome, Outcome::Stopped);
  // The clock moved on by a few hundred ms at most: nothing waited for the targets.
  EXPECT_LT(cell.clock.now() - stop_at, 1s);
}

TEST(Runner, AnInterlockBrokenDuringAStepStopsEveryAxis) {
  Cell cell(kRunAxes + R"(interlocks:
  - {before_moving: x, axis: z, below_mm: 45}
steps:
  - parallel:
      - move: {axis: x, to: 300, speed: 100}
      - move: {axis: z, to: 80, speed: 50}
)");
  const CycleReport r = cell.run();
  EXPECT_FALSE(r.completed);
  EXPECT_THAT(r.ended, HasSubstr("interlock broken during step 1"));
  EXPECT_THAT(r.ended, HasSubstr("z below 45.00 mm before x moves (axis z is at "));
  ASSERT_EQ(r.stood.size(), 2u);
  // Seen within a poll round (both axes: ~50 ms, 2.5 mm at 50 mm/s); every
  // axis gets its RESET pulse before any stop is judged (x's and z's: ~50 ms
  // more), so z stops that far and its deceleration past 45 mm (it ran on to
  // 56 mm when x's stop was judged first), and x far short of 300 mm.
  const int32_t z_stood = r.stood[1].position_001mm;
  EXPECT_EQ(r.stood[1].axis, "z");
  EXPECT_GT(z_stood, 4500);
  EXPECT_LT(z_stood, 5300);
  EXPECT_EQ(cell.position_001mm("z"), z_stood);
  EXPECT_LT(cell.position_001mm("x"), 15000);
  EXPECT_EQ(span(r, 0, 0).outcome, Outcome::Stopped);
}

TEST(Runner, ALineThatFallsSilentMidStepEndsTheCycleAndSaysSo) {
  Cell cell(kRunAxes + "steps:\n  - move: {axis: x, to: 300, speed: 100}\n");
  const TimePoint silent_at = cell.clock.now() + 1s;
  RunOptions o;
  o.stop_requested = [&] {  // polled between transactions: here, the fault's trigger
    if (cell.clock.now() >= silent_at && !cell.bus.faults().any()) {
      sim::FaultConfig f;
      f.drop = 1.0;  // the controllers act on every request but no reply comes back
      cell.bus.set_faults(f);
    }
    return false;
  };
  const CycleReport r = cell.run(o);
  EXPECT_FALSE(r.completed);
  EXPECT_THAT(r.ended, HasSubstr("line fault during step 1 (move x to 300.00 mm): "));
  ASSERT_EQ(r.steps.size(), 1u);
  EXPECT_EQ(r.steps[0].decision, "line fault");
  ASSERT_EQ(r.stood.size(), 2u);
  for (const auto& s : r.stood) {
    EXPECT_FALSE(s.stopped) << s.how;  // no read came back: not claimed at rest
    EXPECT_FALSE(s.how.empty());
  }
  // The stop reached the controller although its replies were lost: x is at
  // rest near 125 mm, not at 300 mm where it would be by now (6 s) unstopped.
  cell.bus.set_faults({});
  const auto x_at = cell.clients.at("x")->read_state();
  EXPECT_EQ(x_at.speed_mm_s, 0);
  EXPECT_LT(x_at.position_001mm, 20000) << r.stood[0].how;
}

// A stop that comes while the runner reads the axes between two steps (lec
// serve shutting down fails those reads): the cycle ends as stopped, every
// axis is stopped, not "refused before step 2: axis does not answer" with
// nothing stopped (a reviewer's finding, 5 of 8 shutdowns of a cycle of waits).
TEST(Runner, AStopDuringTheReadsBetweenStepsEndsTheCycleAsAStop) {
  Cell cell(kRunAxes + "steps:\n  - move: {axis: x, to: 100}\n  - move: {axis: x, to: 0}\n");
  bool step_ended = false, fired = false;
  RunOptions o;
  o.on_step = [&](const StepReport&) { step_ended = true; };
  o.stop_requested = [&] {
    if (step_ended && !fired) {  // the look before the reads: the stop comes just after it
      fired = true;
      sim::FaultConfig f;
      f.drop = 1.0;  // the reads between the steps fail, as a stopping line fails them
      cell.bus.set_faults(f);
      return false;
    }
    return fired;
  };
  const CycleReport r = cell.run(o);
  EXPECT_FALSE(r.completed);
  EXPECT_EQ(r.ended, "stopped by request between steps");
  ASSERT_EQ(r.steps.size(), 1u) << "step 2 never started";
  EXPECT_EQ(r.stood.size(), 2u) << "every axis stopped";
}

// A line fault while a stop is asked is still a line fault where nothing
// says the stop caused it (lec cycle run; RunOptions::failure_is_stop
// unset), and is the stop where something does (lec serve shutting down).
TEST(Runner, AFailedExchangeIsTheStopsOnlyWhenTheCallerSaysSo) {
  for (const bool says : {false, true}) {
    Cell cell(kRunAxes + "steps:\n  - move: {axis: x, to: 300, speed: 100}\n");
    const TimePoint at = cell.clock.now() + 1s;
    RunOptions o;
    o.stop_requested = [&] {
      if (cell.clock.now() < at) return false;
      if (!cell.bus.faults().any()) {
        sim::FaultConfig f;
        f.drop = 1.0;
        cell.bus.set_faults(f);
        return false;  // the exchange under way fails before the stop is looked at
      }
      return true;
    };
    if (says) o.failure_is_stop = [] { return true; };
    const CycleReport r = cell.run(o);
    EXPECT_FALSE(r.completed);
    if (says) {
      EXPECT_THAT(r.ended, HasSubstr("stopped by request during step 1"));
    } else {
      EXPECT_THAT(r.ended, HasSubstr("line fault during step 1"));
    }
    EXPECT_EQ(r.stood.size(), 2u);
  }
}

TEST(Runner, RepeatsTheCycle) {
  Cell cell(kRunAxes + R"(repeat: 3
steps:
  - move: {axis: x, to: 100}
  - move: {axis: x, to: 0}
)");
  const CycleReport r = cell.run();
  ASSERT_TRUE(r.completed) << r.ended;
  EXPECT_EQ(r.iterations, 3u);
  EXPECT_EQ(r.steps.size(), 6u);
  EXPECT_EQ(r.steps[5].path, "2 (3/3)");
}

// Repeat until on the twin: x steps 60 mm at a time until it is past 200 mm
// (four passes: 60, 120, 180, 240), read from the axis after each pass.
TEST(Runner, RepeatUntilReadsTheAxisAfterEachPass) {
  Cell cell(kRunAxes + R"(steps:
  - move: {axis: x, to: 0}
  - repeat:
      times: 10
      until: {axis: x, above_mm: 200}
      steps: [{move: {axis: x, to: 60, relative: true}}]
)");
  const CycleReport r = cell.run();
  ASSERT_TRUE(r.completed) << r.ended;
  EXPECT_EQ(r.steps.size(), 5u);
  EXPECT_EQ(r.steps.back().path, "2.1 (4/10)");
  EXPECT_EQ(cell.position_001mm("x"), 24000);
  // Never met within its passes: the cycle fails, saying which repeat.
  Cell again(kRunAxes + R"(steps:
  - repeat:
      times: 2
      until: {axis: x, above_mm: 390}
      steps: [{move: {axis: x, to: 60, relative: true}}]
)");
  const CycleReport f = again.run();
  EXPECT_FALSE(f.completed);
  EXPECT_EQ(f.ended,
            "step 1 (repeat until x above 390.00 mm, at most 2 times): not met after 2 passes");
}

}  // namespace
}  // namespace lec6::cycle
