// The cycle file: what it reads, and every rule a bad file breaks, each
// named with file, line, column and field before anything moves.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "lec6/cycle/cycle_file.hpp"

namespace lec6::cycle {
namespace {

using ::testing::HasSubstr;

const char* kFileCell = R"(cycle: press-fit
repeat: 2
axes:
  x:
    id: 1
    soft_limits: [0, 400]
    points: {home: 0, pick: 120, place: 300.5}
  z:
    id: 2
    points: {up: 10, down: 80}
    twin: {workpiece_mm: 85}
interlocks:
  - {before_moving: x, axis: z, below_mm: 50}
steps:
  - move: {axis: z, to: up}
  - parallel:
      - move: {axis: x, to: pick, speed: 300, accel: 2000}
      - wait: {axis: z, flag: INP, timeout: 1s}
  - push: {axis: z, to: down, force: 40, trigger: 30, distance: 10, on_miss: reject}
  - run_step: {axis: x, step: 3, on: {alarm: abort}}
  - dwell: 250ms
  - repeat:
      times: 3
      steps:
        - move: {axis: x, to: 10, relative: true}
branches:
  reject:
    - move: {axis: z, to: up}
)";

TEST(CycleFile, ReadsEveryKindOfStep) {
  const Cycle c = parse_cycle(kFileCell, "cell.yaml");
  EXPECT_EQ(c.name, "press-fit");
  EXPECT_EQ(c.repeat, 2u);
  ASSERT_EQ(c.axes.size(), 2u);
  EXPECT_EQ(c.axis("x")->points_001mm.at("place"), 30050);
  EXPECT_EQ(c.axis("x")->soft_limits->max_001mm, 40000);
  EXPECT_DOUBLE_EQ(*c.axis("z")->twin_workpiece_mm, 85.0);
  ASSERT_EQ(c.interlocks.size(), 1u);
  EXPECT_EQ(c.interlocks[0].text, "z below 50.00 mm before x moves");
  ASSERT_EQ(c.steps.size(), 6u);
  EXPECT_EQ(c.steps[0].kind, Step::Kind::Move);
  EXPECT_EQ(*c.steps[0].move.position_001mm, 1000);
  EXPECT_EQ(c.steps[0].text, "move z to up (10.00 mm)");
  // Fields left out keep `lec move`'s defaults (merge_direct at the start).
  EXPECT_FALSE(c.steps[0].move.speed_mm_s);
  EXPECT_EQ(c.steps[0].timeout, std::chrono::seconds(60));
  const Step& group = c.steps[1];
  ASSERT_EQ(group.kind, Step::Kind::Parallel);
  ASSERT_EQ(group.steps.size(), 2u);
  EXPECT_EQ(*group.steps[0].move.speed_mm_s, 300);
  EXPECT_EQ(*group.steps[0].move.acceleration_mm_s2, 2000);
  EXPECT_EQ(group.steps[1].flag, lec::StatusFlags::Inp);
  EXPECT_EQ(group.steps[1].timeout, std::chrono::seconds(1));
  const Step& push = c.steps[2];
  EXPECT_EQ(push.kind, Step::Kind::Push);
  EXPECT_EQ(*push.move.pushing_force_pct, 40);
  EXPECT_EQ(*push.move.trigger_level_pct, 30);
  EXPECT_EQ(*push.move.in_position_001mm, 1000);
  EXPECT_EQ(push.on.at(Outcome::PushMissed).kind, Target::Branch);
  EXPECT_EQ(push.on.at(Outcome::PushMissed).branch, "reject");
  EXPECT_EQ(c.steps[3].stored_step, 3u);
  EXPECT_EQ(c.steps[3].on.at(Outcome::Alarm).kind, Target::Abort);
  EXPECT_EQ(c.steps[4].dwell, std::chrono::milliseconds(250));
  EXPECT_EQ(c.steps[5].times, 3u);
  EXPECT_TRUE(c.steps[5].steps[0].move.relative);
  ASSERT_EQ(c.branches.at("reject").size(), 1u);
}

// The error of `yaml`, which must be refused.
CycleError refused(const std::string& yaml) {
  try {
    parse_cycle(yaml, "cell.yaml");
  } catch (const CycleError& e) {
    return e;
  }
  ADD_FAILURE() << "accepted:\n" << yaml;
  return CycleError("", {}, "", "");
}

const char* kFileAxes = "axes:\n  x: {id: 1, soft_limits: [0, 400], points: {pick: 120}}\n  z: 2\n";

TEST(CycleFile, UnknownAxisNamesFileLineColumnAndField) {
  const auto e = refused(std::string(kFileAxes) + "steps:\n  - move: {axis: y, to: 10}\n");
  EXPECT_EQ(e.file(), "cell.yaml");
  EXPECT_EQ(e.at().line, 5);
  EXPECT_EQ(e.at().column, 18);
  EXPECT_EQ(e.field(), "steps[0].move.axis");
  EXPECT_THAT(e.what(), HasSubstr("cell.yaml:5:18: steps[0].move.axis: unknown axis 'y'"));
}

TEST(CycleFile, UnknownPointIsSuggested) {
  const auto e = refused(std::string(kFileAxes) + "steps:\n  - move: {axis: x, to: pik}\n");
  EXPECT_THAT(e.what(),
              HasSubstr("steps[0].move.to: unknown point of axis x 'pik': did you mean 'pick'?"));
}

TEST(CycleFile, TargetOutsideSoftLimits) {
  const auto e = refused(std::string(kFileAxes) + "steps:\n  - move: {axis: x, to: 450}\n");
  EXPECT_THAT(e.what(), HasSubstr("450.00 mm is outside axis x's soft limits 0.00 to 400.00 mm"));
  EXPECT_EQ(e.field(), "steps[0].move.to");
}

TEST(CycleFile, PointOutsideSoftLimits) {
  const auto e = refused(
      "axes:\n  x: {id: 1, soft_limits: [0, 400], points: {far: 401}}\nsteps:\n  - dwell: 1s\n");
  EXPECT_EQ(e.field(), "axes.x.points.far");
  EXPECT_THAT(e.rule(), HasSubstr("outside the axis's soft limits"));
}

TEST(CycleFile, ParallelGroupMovingOneAxisTwice) {
  const auto e =
      refused(std::string(kFileAxes) +
              "steps:\n  - parallel:\n      - move: {axis: x, to: 10}\n"
              "      - move: {axis: z, to: 10}\n      - push: {axis: x, to: 20, force: 30}\n");
  EXPECT_EQ(e.field(), "steps[0].parallel[2]");
  EXPECT_EQ(e.at().line, 8);
  EXPECT_THAT(
      e.rule(),
      HasSubstr("axis x is moved twice in this parallel group (also by steps[0].parallel[0])"));
}

TEST(CycleFile, WaitWithoutTimeoutOrThatCanNeverEnd) {
  auto e = refused(std::string(kFileAxes) + "steps:\n  - wait: {axis: x, flag: INP}\n");
  EXPECT_EQ(e.field(), "steps[0].wait.timeout");
  EXPECT_THAT(e.rule(), HasSubstr("a wait that may never end is refused"));
  e = refused(std::string(kFileAxes) + "steps:\n  - wait: {axis: x, above_mm: 400, timeout: 2s}\n");
  EXPECT_EQ(e.field(), "steps[0].wait.above_mm");
  EXPECT_THAT(e.rule(), HasSubstr("the wait would never end"));
  e = refused(std::string(kFileAxes) + "steps:\n  - wait: {axis: x, flag: INPP, timeout: 2s}\n");
  EXPECT_THAT(e.rule(), HasSubstr("unknown status flag 'INPP': did you mean 'INP'?"));
}

TEST(CycleFile, RepeatUntilNeedsItsMostPassesAndAConditionThatCanHold) {
  auto e = refused(std::string(kFileAxes) +
                   "steps:\n  - repeat: {until: {axis: z, flag: INP}, steps: [{dwell: 1s}]}\n");
  EXPECT_EQ(e.field(), "steps[0].repeat.times");
  EXPECT_THAT(e.rule(), HasSubstr("a repeat that may never end is refused"));
  e = refused(std::string(kFileAxes) +
              "steps:\n  - repeat: {times: 3, until: {axis: x, above_mm: 400}, steps: [{dwell: "
              "1s}]}\n");
  EXPECT_EQ(e.field(), "steps[0].repeat.until.above_mm");
  EXPECT_THAT(e.rule(), HasSubstr("the repeat's until would never end"));
  e = refused(std::string(kFileAxes) +
              "steps:\n  - repeat: {times: 3, until: {axis: z}, steps: [{dwell: 1s}]}\n");
  EXPECT_THAT(e.rule(),
              HasSubstr("a repeat's until needs exactly one of flag, above_mm or below_mm"));
  e = refused(std::string(kFileAxes) +
              "steps:\n  - repeat: {times: 3, until: {axis: z, flag: INP, timeout: 2s}, steps: "
              "[{dwell: 1s}]}\n");
  EXPECT_EQ(e.field(), "steps[0].repeat.until.timeout");
  EXPECT_THAT(e.rule(), HasSubstr("timeout"));
}

TEST(CycleFile, BranchesMustExistAndNotCallThemselves) {
  auto e = refused(std::string(kFileAxes) +
                   "steps:\n  - push: {axis: z, to: 10, force: 30, on_miss: rejct}\n"
                   "branches:\n  reject:\n    - dwell: 1s\n");
  EXPECT_EQ(e.field(), "steps[0].push.on_miss");
  EXPECT_THAT(e.rule(), HasSubstr("unknown branch 'rejct': did you mean 'reject'?"));
  e = refused(std::string(kFileAxes) +
              "steps:\n  - dwell: 1s\nbranches:\n  a:\n    - push: {axis: z, to: 10, force: 30, "
              "on_miss: b}\n"
              "  b:\n    - push: {axis: z, to: 10, force: 30, on: {push_missed: a}}\n");
  EXPECT_THAT(e.rule(), HasSubstr("the branch can call itself (a -> b -> a)"));
}

TEST(CycleFile, DirectDataRulesOfTheManual) {
  auto e = refused(std::string(kFileAxes) +
                   "steps:\n  - push: {axis: z, to: 10, force: 30, trigger: 50}\n");
  EXPECT_THAT(e.rule(), HasSubstr("trigger level"));
  e = refused(std::string(kFileAxes) + "steps:\n  - move: {axis: z, to: 10, speed: 70000}\n");
  EXPECT_EQ(e.field(), "steps[0].move.speed");
  e = refused(std::string(kFileAxes) + "steps:\n  - push: {axis: z, to: 10}\n");
  EXPECT_EQ(e.field(), "steps[0].push.force");
}

TEST(CycleFile, UnknownKeysAndBadYaml) {
  auto e = refused(std::string(kFileAxes) + "steps:\n  - move: {axis: x, to: 10, sped: 100}\n");
  EXPECT_EQ(e.field(), "steps[0].move.sped");
  EXPECT_THAT(e.rule(), HasSubstr("did you mean 'speed'?"));
  e = refused(std::string(kFileAxes) + "steps:\n  - move: {axis: x, to: [10\n");
  EXPECT_THAT(e.rule(), HasSubstr("not valid YAML"));
  EXPECT_GT(e.at().line, 0);
  e = refused(std::string(kFileAxes) + "steps:\n  - move: {axis: x, to: 10}\n    dwell: 1s\n");
  EXPECT_THAT(e.rule(), HasSubstr("one kind per step"));
  e = refused("axes:\n  x: {id: 1}\n  z: {id: 1}\nsteps:\n  - dwell: 1s\n");
  EXPECT_THAT(e.rule(), HasSubstr("ID 1 is also axis 'x'"));
}

TEST(CycleFile, InterlocksNameKnownAxesAndReachableLimits) {
  auto e =
      refused(std::string(kFileAxes) +
              "interlocks:\n  - {before_moving: x, axis: q, above_mm: 5}\nsteps:\n  - dwell: 1s\n");
  EXPECT_EQ(e.field(), "interlocks[0].axis");
  e = refused(
      std::string(kFileAxes) +
      "interlocks:\n  - {before_moving: z, axis: x, above_mm: 400}\nsteps:\n  - dwell: 1s\n");
  EXPECT_THAT(e.rule(), HasSubstr("can never be above 400.00 mm"));
}

TEST(CycleFile, UnreadableFile) {
  try {
    load_cycle("/nonexistent/cell.yaml");
    FAIL();
  } catch (const CycleError& e) {
    EXPECT_THAT(
        e.what(),
        HasSubstr("/nonexistent/cell.yaml: cannot read the file: No such file or directory"));
  }
  // A directory opens as a stream on Linux and reads as nothing: said as what it is.
  try {
    load_cycle("/tmp");
    FAIL();
  } catch (const CycleError& e) {
    EXPECT_THAT(e.what(), HasSubstr("/tmp: cannot read the file: it is a directory"));
  }
}

}  // namespace
}  // namespace lec6::cycle
