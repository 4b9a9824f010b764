// Issue 32, rule 5, on the twin: a controller whose INP rises after BUSY fell
// (ActuatorConfig::inp_delay, the drive settling in its band) gives reached
// moves whose settle time is measured between the polls that bracket both
// edges, within a poll gap of the truth, never 0.

#include <gtest/gtest.h>

#include <cmath>

#include "sim_fixture.hpp"

namespace lec6::client {
namespace {

using testing::SimFixture;

TEST(Settle, TheTwinsLateInpIsWaitedForAndTimedWithinAPollGap) {
  sim::ActuatorConfig config;
  config.inp_delay = std::chrono::milliseconds(120);
  SimFixture f({}, {1}, config);
  f.prepare();
  for (int i = 0; i < 10; ++i) {
    DirectMove d;
    d.position_001mm = i % 2 == 0 ? 3000 : 1000;
    d.speed_mm_s = 100;
    const MoveResult r = f.axis->move(d, f.axis->deadline_in(std::chrono::seconds(5)));
    ASSERT_EQ(r.outcome, MoveOutcome::Reached) << "INP after BUSY fell is a reached move";
    const MoveTimeline& t = r.timeline;
    ASSERT_TRUE(t.busy_down && t.busy_down_after && t.inp && t.inp_after);
    const double down = to_seconds(*t.busy_down + *t.busy_down_after) / 2;
    const double inp = to_seconds(*t.inp + *t.inp_after) / 2;
    const double gap = to_seconds(*t.inp - *t.inp_after);  // one poll
    EXPECT_GT(inp - down, 0.06);
    EXPECT_LE(std::abs((inp - down) - 0.120), gap + 1e-9) << "move " << i;
  }
  // Without the delay INP comes with BUSY's fall: one poll sees both, 0.
  SimFixture g;
  g.prepare();
  DirectMove d;
  d.position_001mm = 3000;
  const MoveResult r = g.axis->move(d, g.axis->deadline_in(std::chrono::seconds(5)));
  EXPECT_EQ(r.timeline.inp, r.timeline.busy_down);
}

}  // namespace
}  // namespace lec6::client
