// cycle::analyse: the critical path tiles the cycle time whatever the
// report holds (a property over random reports), each step's share goes to
// the line, the axes or the program as documented, and on the twin a cycle's
// motion and line shares and the line's utilisation come out as the moves
// and the exchanges say.

#include "lec6/cycle/analysis.hpp"

#include <gtest/gtest.h>

#include <random>

#include "cell_fixture.hpp"

namespace lec6::cycle {
namespace {

using namespace std::chrono_literals;

AxisSpan motion(std::string axis, Duration start, Duration end) {
  AxisSpan a;
  a.axis = std::move(axis);
  a.start = start;
  a.end = end;
  a.outcome = Outcome::Reached;
  a.motion = true;
  return a;
}

// The path starts at 0, each segment where the last ended, the last at the
// cycle time; the three shares add up to it.
void expect_tiles(const CycleAnalysis& a) {
  Duration at{};
  for (const auto& s : a.critical_path) {
    ASSERT_EQ(s.from, at) << share_name(s.share) << " of step " << s.step;
    ASSERT_GT(s.to, s.from) << share_name(s.share) << " of step " << s.step;
    at = s.to;
  }
  EXPECT_EQ(at, a.cycle_time);
  EXPECT_EQ(a.line + a.motion + a.program, a.cycle_time);
}

TEST(CycleAnalysis, AGroupsLastMemberIsOnThePathAndTheRestIsTheLine) {
  CycleReport r;
  StepReport group{"1", "parallel", 40ms, 2100ms, {}, "continue"};
  group.axes.push_back(motion("x", 60ms, 1500ms));
  AxisSpan z = motion("z", 75ms, 2080ms);
  z.busy_fell_after = 2030ms;
  z.busy_fell_by = 2060ms;
  group.axes.push_back(z);
  StepReport dwell{"2", "dwell 200ms", 2150ms, 2360ms, {}, "continue"};
  AxisSpan d;
  d.start = 2150ms;
  d.end = 2350ms;
  dwell.axes.push_back(d);
  r.steps = {group, dwell};
  r.cycle_time = 2400ms;
  r.lines.push_back({"twin", {"x", "z"}, 120, 0, 600ms});

  const CycleAnalysis a = analyse(r);
  expect_tiles(a);
  ASSERT_EQ(a.steps.size(), 2u);
  EXPECT_EQ(a.steps[0].critical_axis, "z");
  EXPECT_EQ(a.steps[0].start_skew, 15ms);
  EXPECT_EQ(a.max_start_skew, 15ms);
  // reads 40, start 35, motion 1955, seen 50, after 20
  EXPECT_EQ(a.steps[0].motion, 1955ms);
  EXPECT_EQ(a.steps[0].line, 40ms + 35ms + 50ms + 20ms);
  EXPECT_EQ(a.steps[1].program, 200ms);
  EXPECT_EQ(a.steps[1].line, 50ms + 10ms);
  EXPECT_EQ(a.critical_path.back().share, Share::Tail);
  EXPECT_EQ(a.motion, 1955ms);
  EXPECT_EQ(a.program, 200ms);
  ASSERT_EQ(a.axes.size(), 2u);
  EXPECT_EQ(a.axes[0].moving, 1440ms);
  EXPECT_EQ(a.axes[1].motions, 1u);
  ASSERT_EQ(a.lines.size(), 1u);
  ASSERT_TRUE(a.lines[0].utilisation);
  EXPECT_DOUBLE_EQ(*a.lines[0].utilisation, 0.25);
}

TEST(CycleAnalysis, ARefusedMoveIsNoMotionAndAnUnknownLineStaysUnknown) {
  CycleReport r;
  StepReport s{"1", "move x", 30ms, 101ms, {}, "abort"};
  AxisSpan refused = motion("x", 30ms, 100ms);  // its checks' reads took 70 ms
  refused.outcome = Outcome::Refused;
  s.axes.push_back(refused);
  r.steps = {s};
  r.cycle_time = 150ms;                                  // the stops after the abort
  r.lines.push_back({"tcp://gw:502", {"x"}, 6, 0, {}});  // a gateway: busy not known
  const CycleAnalysis a = analyse(r);
  expect_tiles(a);
  EXPECT_EQ(a.motion, 0ms);
  EXPECT_EQ(a.steps.at(0).line, 101ms);
  EXPECT_EQ(a.axes.at(0).motions, 0u);
  EXPECT_FALSE(a.lines.at(0).utilisation);
  EXPECT_FALSE(a.max_start_skew);
}

// Whatever the times (out of order, overlapping, past the step's end, a
// BUSY bracket before the start), the path tiles the cycle time.
TEST(CycleAnalysis, ThePathTilesTheCycleTimeInEveryRandomReport) {
  std::mt19937 rng(34);
  auto ms = [&](int lo, int hi) {
    return Duration(std::chrono::milliseconds(std::uniform_int_distribution<int>(lo, hi)(rng)));
  };
  for (int round = 0; round < 2000; ++round) {
    CycleReport r;
    Duration t = ms(0, 50);
    const int steps = std::uniform_int_distribution<int>(0, 6)(rng);
    for (int i = 0; i < steps; ++i) {
      StepReport s{std::to_string(i + 1), "step", t + ms(-20, 60), {}, {}, "continue"};
      s.end = s.start + ms(-10, 3000);
      const int members = std::uniform_int_distribution<int>(0, 3)(rng);
      for (int m = 0; m < members; ++m) {
        AxisSpan a = motion(m % 2 ? "z" : "x", s.start + ms(-30, 200), {});
        a.end = a.start + ms(-10, 3000);
        a.motion = (round + m) % 3 != 0;
        if (m == 2) a.axis.clear();
        if (a.motion && round % 2) a.busy_fell_after = a.start + ms(-100, 3000);
        s.axes.push_back(a);
      }
      r.steps.push_back(s);
      t = std::max(t, s.end) + ms(0, 80);
    }
    r.cycle_time = t + ms(-100, 100);
    if (r.cycle_time < Duration::zero()) r.cycle_time = 0ms;
    SCOPED_TRACE(round);
    expect_tiles(analyse(r));
    if (::testing::Test::HasFatalFailure()) return;
  }
}

TEST(CycleAnalysis, ACycleOnTheTwinSplitsIntoMotionAndLine) {
  testing::Cell cell(R"(axes:
  x: {id: 1, soft_limits: [0, 400]}
  z: {id: 2}
steps:
  - parallel:
      - move: {axis: x, to: 300, speed: 200}
      - move: {axis: z, to: 80, speed: 40}
  - dwell: 300ms
  - move: {axis: x, to: 0, speed: 300}
)");
  const CycleReport r = cell.run();
  ASSERT_TRUE(r.completed) << r.ended;
  const CycleAnalysis a = analyse(r);
  expect_tiles(a);
  // z's 80 mm at 40 mm/s is the group's critical member, x's 300 mm at
  // 300 mm/s the last step's: motion at least their motion times.
  EXPECT_EQ(a.steps.at(0).critical_axis, "z");
  EXPECT_GT(a.steps.at(0).motion, 1500ms);
  EXPECT_GT(a.steps.at(2).motion, 950ms);
  EXPECT_EQ(a.program, 300ms);
  // Every move's BUSY fall was bracketed by its polls.
  for (const auto& s : r.steps) {
    for (const auto& m : s.axes) {
      if (!m.motion) continue;
      ASSERT_TRUE(m.busy_fell_after && m.busy_fell_by) << s.path << " " << m.axis;
      EXPECT_LT(*m.busy_fell_after, *m.busy_fell_by);
      EXPECT_LE(*m.busy_fell_by, m.end);
    }
  }
  // The line: busy for part of the cycle, every exchange counted.
  ASSERT_EQ(a.lines.size(), 1u);
  EXPECT_EQ(a.lines[0].axes, (std::vector<std::string>{"x", "z"}));
  EXPECT_GT(a.lines[0].transactions, 20u);
  ASSERT_TRUE(a.lines[0].utilisation);
  EXPECT_GT(*a.lines[0].utilisation, 0.05);
  EXPECT_LT(*a.lines[0].utilisation, 1.0);
  EXPECT_GT(a.line, 0ms);
  ASSERT_TRUE(a.max_start_skew);
  EXPECT_LT(*a.max_start_skew, 25ms);  // one start transaction (runner_test)
  EXPECT_NEAR(a.axes.at(0).utilisation + 0.0,
              to_seconds(a.axes.at(0).moving) / to_seconds(r.cycle_time), 1e-9);
}

}  // namespace
}  // namespace lec6::cycle
