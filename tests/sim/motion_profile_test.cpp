#include "lec6/sim/motion_profile.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace lec6::sim {
namespace {

const TimePoint t0_profile = TimePoint{} + std::chrono::milliseconds(1000);

double ms_since(TimePoint t, TimePoint from) {
  return to_ms(t - from);
}

TEST(MotionProfile, TrapezoidManualExampleTakes700ms) {
  // Manual §7.3.1: 300.00 mm at 500 mm/s, 5000 mm/s² both ways.
  const auto p = MotionProfile::plan(t0_profile, 0.0, 0.0, 300.0, {500.0, 5000.0, 5000.0});
  EXPECT_NEAR(ms_since(p.end_time(), t0_profile), 700.0, 1.0);
  EXPECT_DOUBLE_EQ(p.final_position(), 300.0);
  // Accelerating phase: 0.1 s to reach 500 mm/s over 25 mm.
  EXPECT_NEAR(p.position(t0_profile + std::chrono::milliseconds(100)), 25.0, 1e-6);
  EXPECT_NEAR(p.velocity(t0_profile + std::chrono::milliseconds(100)), 500.0, 1e-6);
  EXPECT_NEAR(p.at(t0_profile + std::chrono::milliseconds(50)).acceleration, 5000.0, 1e-9);
  // Cruise.
  EXPECT_NEAR(p.position(t0_profile + std::chrono::milliseconds(350)), 150.0, 1e-6);
  EXPECT_NEAR(p.at(t0_profile + std::chrono::milliseconds(350)).acceleration, 0.0, 1e-9);
  // Braking.
  EXPECT_NEAR(p.position(t0_profile + std::chrono::milliseconds(600)), 275.0, 1e-6);
  EXPECT_NEAR(p.at(t0_profile + std::chrono::milliseconds(650)).acceleration, -5000.0, 1e-9);
  // At rest after the end, before the start it is the start state.
  EXPECT_DOUBLE_EQ(p.position(t0_profile + std::chrono::milliseconds(5000)), 300.0);
  EXPECT_DOUBLE_EQ(p.velocity(t0_profile + std::chrono::milliseconds(5000)), 0.0);
  EXPECT_DOUBLE_EQ(p.position(t0_profile - std::chrono::milliseconds(5)), 0.0);
  EXPECT_TRUE(p.moving(t0_profile + std::chrono::milliseconds(699)));
  EXPECT_FALSE(p.moving(t0_profile + std::chrono::milliseconds(701)));
}

TEST(MotionProfile, TriangularWhenTooShortForCruise) {
  // 10 mm at up to 500 mm/s, 1000 mm/s²: peak sqrt(1000·10) = 100 mm/s, 0.2 s total.
  const auto p = MotionProfile::plan(t0_profile, 5.0, 0.0, 15.0, {500.0, 1000.0, 1000.0});
  EXPECT_NEAR(ms_since(p.end_time(), t0_profile), 200.0, 1e-3);
  EXPECT_NEAR(p.velocity(t0_profile + std::chrono::milliseconds(100)), 100.0, 1e-6);
  EXPECT_NEAR(p.position(t0_profile + std::chrono::milliseconds(100)), 10.0, 1e-6);
  EXPECT_EQ(p.segments().size(), 2u);
}

TEST(MotionProfile, AsymmetricTriangle) {
  // a = 1000, d = 4000, 50 mm: vp² = 2·a·d·D/(a+d) = 80000 → vp = 282.84.
  const auto p = MotionProfile::plan(t0_profile, 0.0, 0.0, -50.0, {1000.0, 1000.0, 4000.0});
  const double vp = std::sqrt(80000.0);
  EXPECT_NEAR(to_seconds(p.end_time() - t0_profile), vp / 1000.0 + vp / 4000.0, 1e-6);
  EXPECT_DOUBLE_EQ(p.final_position(), -50.0);
  EXPECT_LT(p.velocity(t0_profile + std::chrono::milliseconds(100)), 0.0);
}

TEST(MotionProfile, RetargetMidMoveIsContinuous) {
  const auto first = MotionProfile::plan(t0_profile, 0.0, 0.0, 300.0, {500.0, 5000.0, 5000.0});
  const TimePoint tr = t0_profile + std::chrono::milliseconds(300);
  const Kinematics k = first.at(tr);
  ASSERT_NEAR(k.velocity, 500.0, 1e-6);
  // Retarget further: keeps cruising, no stop.
  const auto further =
      MotionProfile::plan(tr, k.position, k.velocity, 350.0, {500.0, 5000.0, 5000.0});
  EXPECT_NEAR(further.position(tr), k.position, 1e-9);
  EXPECT_NEAR(further.velocity(tr + std::chrono::milliseconds(1)), 500.0, 1e-6);
  // At 125 mm: 200 mm of cruise (0.4 s) then 25 mm of braking (0.1 s).
  EXPECT_NEAR(to_ms(further.end_time() - tr), 500.0, 1e-3);
  // Retarget behind the carriage: brakes, comes back.
  const auto back = MotionProfile::plan(tr, k.position, k.velocity, 50.0, {500.0, 5000.0, 5000.0});
  EXPECT_DOUBLE_EQ(back.final_position(), 50.0);
  EXPECT_NEAR(back.position(back.end_time()), 50.0, 1e-9);
  // It overshoots forward by v²/2d = 25 mm before turning.
  const TimePoint turn = tr + std::chrono::milliseconds(100);
  EXPECT_NEAR(back.velocity(turn), 0.0, 1e-6);
  EXPECT_NEAR(back.position(turn), k.position + 25.0, 1e-6);
  // Retarget at a slower speed: decelerates down to it first.
  const auto slower =
      MotionProfile::plan(tr, k.position, k.velocity, 300.0, {100.0, 5000.0, 5000.0});
  EXPECT_NEAR(slower.velocity(tr + std::chrono::milliseconds(80)), 100.0, 1e-6);
  EXPECT_NEAR(slower.position(slower.end_time()), 300.0, 1e-6);
  // Moving away from the new target: brake first.
  const auto away = MotionProfile::plan(t0_profile, 100.0, -200.0, 200.0, {500.0, 5000.0, 2000.0});
  EXPECT_NEAR(away.velocity(t0_profile + std::chrono::milliseconds(100)), 0.0, 1e-6);
  EXPECT_NEAR(away.position(t0_profile + std::chrono::milliseconds(100)), 90.0, 1e-6);
  EXPECT_NEAR(away.position(away.end_time()), 200.0, 1e-6);
}

TEST(MotionProfile, StopProfile) {
  const auto s = MotionProfile::stop(t0_profile, 100.0, 400.0, 2000.0);
  EXPECT_NEAR(to_ms(s.end_time() - t0_profile), 200.0, 1e-6);
  EXPECT_NEAR(s.final_position(), 140.0, 1e-9);
  EXPECT_NEAR(s.position(s.end_time()), 140.0, 1e-9);
  const auto rev = MotionProfile::stop(t0_profile, 0.0, -100.0, 1000.0);
  EXPECT_NEAR(rev.final_position(), -5.0, 1e-9);
  const auto rest = MotionProfile::stop(t0_profile, 7.0, 0.0, 1000.0);
  EXPECT_EQ(rest.end_time(), t0_profile);
  EXPECT_DOUBLE_EQ(rest.position(t0_profile + std::chrono::milliseconds(10)), 7.0);
}

TEST(MotionProfile, FirstCrossing) {
  const auto p = MotionProfile::plan(t0_profile, 0.0, 0.0, 300.0, {500.0, 5000.0, 5000.0});
  auto c = p.first_crossing(25.0, t0_profile);
  ASSERT_TRUE(c);
  EXPECT_NEAR(to_ms(*c - t0_profile), 100.0, 1e-3);
  c = p.first_crossing(150.0, t0_profile);
  ASSERT_TRUE(c);
  EXPECT_NEAR(to_ms(*c - t0_profile), 350.0, 1e-3);
  EXPECT_FALSE(p.first_crossing(301.0, t0_profile));
  EXPECT_FALSE(p.first_crossing(-1.0, t0_profile));
  c = p.first_crossing(300.0, t0_profile);
  ASSERT_TRUE(c);
  EXPECT_NEAR(to_ms(*c - t0_profile), 700.0, 1e-3);
  // Searching after a crossing finds none.
  EXPECT_FALSE(p.first_crossing(25.0, t0_profile + std::chrono::milliseconds(200)));
  // Overshooting profile crosses 60 twice; the first is found, then the second.
  const auto back = MotionProfile::plan(t0_profile, 50.0, 500.0, 50.0, {500.0, 5000.0, 5000.0});
  auto c1 = back.first_crossing(60.0, t0_profile);
  ASSERT_TRUE(c1);
  auto c2 = back.first_crossing(60.0, *c1 + std::chrono::milliseconds(1));
  ASSERT_TRUE(c2);
  EXPECT_GT(*c2, *c1);
  EXPECT_NEAR(back.position(*c2), 60.0, 1e-6);
}

TEST(MotionProfile, HaltedAt) {
  const auto p = MotionProfile::plan(t0_profile, 0.0, 0.0, 300.0, {500.0, 5000.0, 5000.0});
  const auto h = p.halted_at(t0_profile + std::chrono::milliseconds(350));
  EXPECT_NEAR(h.final_position(), 150.0, 1e-6);
  EXPECT_EQ(h.end_time(), t0_profile + std::chrono::milliseconds(350));
  EXPECT_NEAR(h.position(t0_profile + std::chrono::milliseconds(100)), 25.0, 1e-6);
  EXPECT_NEAR(h.position(t0_profile + std::chrono::milliseconds(900)), 150.0, 1e-6);
  EXPECT_DOUBLE_EQ(h.velocity(t0_profile + std::chrono::milliseconds(900)), 0.0);
}

}  // namespace
}  // namespace lec6::sim
