// The engine alone (sans-I/O): the order of steps through repeats and
// branches, the decisions on outcomes, and the interlocks refusing.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "lec6/cycle/cycle_file.hpp"
#include "lec6/cycle/engine.hpp"

namespace lec6::cycle {
namespace {

using ::testing::HasSubstr;

AxisState ready_axis(int32_t position_001mm) {
  AxisState a;
  a.flags.set(lec::StatusFlags::Svre, true);
  a.flags.set(lec::StatusFlags::Seton, true);
  a.state.position_001mm = position_001mm;
  a.state.target_001mm = position_001mm;
  return a;
}

const char* kEngineCell = R"(repeat: 2
axes:
  x: {id: 1, soft_limits: [0, 400]}
  z: {id: 2}
interlocks:
  - {before_moving: x, axis: z, below_mm: 50}
steps:
  - push: {axis: z, to: 80, force: 40, on_miss: reject}
  - repeat: {times: 2, steps: [{move: {axis: x, to: 10, relative: true}}]}
branches:
  reject:
    - move: {axis: z, to: 0}
)";

// Runs the engine with every activity ending as `outcome_of(path)` says.
// `after`, when given, changes the axes' states once a batch has run.
std::vector<std::string> engine_walk(const Cycle& c, AxisStates axes,
                                     std::function<Outcome(const Batch&)> outcome, Finished& end,
                                     std::function<void(const Batch&, AxisStates&)> after = {}) {
  Engine e(c);
  std::vector<std::string> paths;
  for (;;) {
    auto next = e.next(axes);
    if (auto* f = std::get_if<Finished>(&next)) {
      end = *f;
      return paths;
    }
    const Batch& b = std::get<Batch>(next);
    paths.push_back(b.path);
    if (after) after(b, axes);
    std::vector<ActivityResult> r(b.activities.size(), ActivityResult{outcome(b), ""});
    e.finished(r);
  }
}

TEST(Engine, WalksRepeatsAndTheWholeCycleNTimes) {
  const Cycle c = parse_cycle(kEngineCell, "cell.yaml");
  Finished end;
  const auto paths = engine_walk(
      c, {{"x", ready_axis(0)}, {"z", ready_axis(0)}},
      [](const Batch& b) {
        return b.step->kind == Step::Kind::Push ? Outcome::Pushed : Outcome::Reached;
      },
      end);
  EXPECT_THAT(paths, ::testing::ElementsAre("1 (1/2)", "2.1 (1/2)", "2.1 (2/2)", "1 (2/2)",
                                            "2.1 (1/2)", "2.1 (2/2)"));
  EXPECT_TRUE(end.completed);
}

// Repeat until (issue 34): the condition is read after each pass; met, the
// cycle goes on; not met after `times` passes, the cycle fails saying so.
TEST(Engine, RepeatUntilEndsWhenItsConditionHoldsOrFailsAfterItsPasses) {
  const Cycle c = parse_cycle(R"(axes:
  x: {id: 1}
  z: {id: 2}
steps:
  - repeat:
      times: 4
      until: {axis: z, flag: INP}
      steps: [{move: {axis: x, to: 10, relative: true}}, {dwell: 100ms}]
  - dwell: 1s
)",
                              "cell.yaml");
  const auto walk = [&](int met_after_pass, Finished& end) {
    int passes = 0;
    return engine_walk(
        c, {{"x", ready_axis(0)}, {"z", ready_axis(0)}},
        [](const Batch& b) {
          return b.step->kind == Step::Kind::Dwell ? Outcome::Done : Outcome::Reached;
        },
        end,
        [&](const Batch& b, AxisStates& axes) {
          if (b.path.starts_with("1.2") && ++passes == met_after_pass)
            axes["z"].flags.set(lec::StatusFlags::Inp, true);
        });
  };
  Finished end;
  EXPECT_THAT(walk(2, end),
              ::testing::ElementsAre("1.1 (1/4)", "1.2 (1/4)", "1.1 (2/4)", "1.2 (2/4)", "2"));
  EXPECT_TRUE(end.completed) << end.reason;
  const auto never = walk(99, end);
  EXPECT_EQ(never.size(), 8u);  // four passes of two steps, and not step 2
  EXPECT_FALSE(end.completed);
  EXPECT_EQ(end.reason, "step 1 (repeat until z INP = 1, at most 4 times): not met after 4 passes");
}

// Engine::next_needs (what the Runner reads before each step): flags and
// state before every step that moves, wait, group and repeat's `until`; the
// flags only before a dwell (alone, in a repeat, as a repeat's first step);
// nothing at the cycle's end. Groups and waits here do not follow an `until`
// (which asks for a read of its own).
TEST(Engine, ReadsTheAxesForWhatEachDecisionJudges) {
  const Cycle c = parse_cycle(R"(axes:
  x: {id: 1}
  z: {id: 2}
steps:
  - dwell: 100ms
  - move: {axis: x, to: 10}
  - repeat: {times: 2, steps: [{dwell: 50ms}]}
  - parallel: [{dwell: 50ms}, {move: {axis: z, to: 5}}]
  - dwell: 50ms
  - wait: {axis: z, flag: INP, timeout: 1s}
  - dwell: 50ms
  - parallel: [{dwell: 50ms}, {dwell: 60ms}]
  - repeat:
      times: 2
      until: {axis: z, flag: INP}
      steps: [{dwell: 50ms}]
  - dwell: 50ms
  - push: {axis: z, to: 80, force: 40, on_miss: reject}
branches:
  reject:
    - move: {axis: z, to: 0}
)",
                              "cell.yaml");
  AxisStates axes{{"x", ready_axis(0)}, {"z", ready_axis(0)}};
  axes["z"].flags.set(lec::StatusFlags::Inp, true);  // the until holds after its first pass
  Engine e(c);
  std::vector<std::string> seen;  // "path: what" before each batch, then the end
  const auto what = [](Engine::AxesNeeded n) {
    return n == Engine::AxesNeeded::Nothing ? "-"
           : n == Engine::AxesNeeded::Flags ? "flags"
                                            : "all";
  };
  for (;;) {
    const auto need = e.next_needs();
    auto next = e.next(axes);
    if (auto* f = std::get_if<Finished>(&next)) {
      EXPECT_TRUE(f->completed) << f->reason;
      seen.push_back(std::string("end: ") + what(need));
      break;
    }
    const Batch& b = std::get<Batch>(next);
    seen.push_back(b.path + ": " + what(need));
    // The push misses: the branch runs, its first step a move.
    const Outcome o = b.step->kind == Step::Kind::Push ? Outcome::PushMissed : Outcome::Done;
    e.finished(std::vector<ActivityResult>(b.activities.size(), ActivityResult{o, ""}));
  }
  EXPECT_THAT(seen, ::testing::ElementsAre("1: flags", "2: all", "3.1 (1/2): flags",
                                           "3.1 (2/2): flags", "4: all", "5: flags", "6: all",
                                           "7: flags", "8: all", "9.1 (1/2): flags", "10: all",
                                           "11: all", "reject.1: all", "end: -"));
  EXPECT_EQ(e.next_needs(), Engine::AxesNeeded::Nothing);  // ended: nothing more to judge
}

TEST(Engine, PushMissedRunsTheBranchThenGoesOn) {
  const Cycle c = parse_cycle(kEngineCell, "cell.yaml");
  Finished end;
  const auto paths = engine_walk(
      c, {{"x", ready_axis(0)}, {"z", ready_axis(0)}},
      [](const Batch& b) {
        return b.step->kind == Step::Kind::Push ? Outcome::PushMissed : Outcome::Reached;
      },
      end);
  EXPECT_EQ(paths[0], "1 (1/2)");
  EXPECT_EQ(paths[1], "reject.1");
  EXPECT_EQ(paths[2], "2.1 (1/2)");
  EXPECT_TRUE(end.completed);
}

TEST(Engine, AnOutcomeWithoutAWordAborts) {
  const Cycle c = parse_cycle(kEngineCell, "cell.yaml");
  Finished end;
  const auto paths = engine_walk(
      c, {{"x", ready_axis(0)}, {"z", ready_axis(0)}}, [](const Batch&) { return Outcome::Alarm; },
      end);
  EXPECT_EQ(paths.size(), 1u);
  EXPECT_FALSE(end.completed);
  EXPECT_THAT(end.reason, HasSubstr("aborted at step 1 (1/2) (push z to 80.00 mm): alarm"));
}

TEST(Engine, InterlocksRefuseBeforeTheStep) {
  const Cycle c = parse_cycle(kEngineCell, "cell.yaml");
  const auto pushed = [](const Batch&) { return Outcome::Pushed; };
  Finished end;
  // The user's rule: z below 50 mm before x moves (z is at 60).
  auto paths = engine_walk(c, {{"x", ready_axis(0)}, {"z", ready_axis(6000)}}, pushed, end);
  EXPECT_EQ(paths.size(), 1u);  // the push ran; x's move was refused
  EXPECT_FALSE(end.completed);
  EXPECT_THAT(end.reason,
              HasSubstr("refused before step 2.1 (1/2) (move x by 10.00 mm): interlock: "
                        "z below 50.00 mm before x moves (axis z is at 60.00 mm)"));
  // Not homed.
  AxisState z = ready_axis(0);
  z.flags.set(lec::StatusFlags::Seton, false);
  paths = engine_walk(c, {{"x", ready_axis(0)}, {"z", z}}, pushed, end);
  EXPECT_TRUE(paths.empty());
  EXPECT_THAT(end.reason, HasSubstr("axis z is not homed (SETON = 0)"));
  // An alarm on an axis the step does not move.
  AxisState x = ready_axis(0);
  x.flags.set(lec::StatusFlags::Alarm, true);
  engine_walk(c, {{"x", x}, {"z", ready_axis(0)}}, pushed, end);
  EXPECT_THAT(end.reason, HasSubstr("axis x has an alarm"));
  // Servo not ready.
  z = ready_axis(0);
  z.flags.set(lec::StatusFlags::Svre, false);
  engine_walk(c, {{"x", ready_axis(0)}, {"z", z}}, pushed, end);
  EXPECT_THAT(end.reason, HasSubstr("axis z is not servo ready (SVRE = 0)"));
  // A relative move out of the soft limits (x's target is 395 mm).
  x = ready_axis(39500);
  engine_walk(c, {{"x", x}, {"z", ready_axis(0)}}, pushed, end);
  EXPECT_THAT(end.reason,
              HasSubstr("target 405.00 mm is beyond the soft limits 0.00 to 400.00 mm"));
  // An axis that does not answer.
  x = ready_axis(0);
  x.answered = false;
  engine_walk(c, {{"x", x}, {"z", ready_axis(0)}}, pushed, end);
  EXPECT_THAT(end.reason, HasSubstr("axis x does not answer"));
}

TEST(Engine, ConditionsContinueOrTakeTheFirstBranchOfAGroup) {
  const Cycle c = parse_cycle(R"(axes: {x: 1, z: 2}
steps:
  - parallel:
      - push: {axis: x, to: 10, force: 30, on: {push_missed: continue}}
      - push: {axis: z, to: 10, force: 30, on_miss: b}
  - parallel:
      - push: {axis: x, to: 10, force: 30, on_miss: a}
      - push: {axis: z, to: 10, force: 30, on_miss: b}
branches:
  a: [{dwell: 1s}]
  b: [{dwell: 2s}]
)",
                              "cell.yaml");
  Finished end;
  const auto paths = engine_walk(
      c, {{"x", ready_axis(0)}, {"z", ready_axis(0)}},
      [](const Batch& b) {
        return b.step->kind == Step::Kind::Parallel ? Outcome::PushMissed : Outcome::Done;
      },
      end);
  // Group 1: x continues, z branches to b; group 2: both branch, a (first in the file) is taken.
  EXPECT_THAT(paths, ::testing::ElementsAre("1", "b.1", "2", "a.1"));
  EXPECT_TRUE(end.completed);
}

TEST(Engine, OneResultPerActivity) {
  const Cycle c = parse_cycle(kEngineCell, "cell.yaml");
  Engine e(c);
  ASSERT_TRUE(std::holds_alternative<Batch>(e.next({{"x", ready_axis(0)}, {"z", ready_axis(0)}})));
  EXPECT_THROW(e.finished({}), InvalidArgument);
}

}  // namespace
}  // namespace lec6::cycle
