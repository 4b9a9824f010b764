// The twin's assumptions as named parameters (issue 33, docs/twin-fidelity.md
// rows R-MOTION-HOMING, R-FLAG-SETON-REHOME, R-FLAG-RESET-HOMING,
// R-MOTION-RETARGET, R-FLAG-ALARM-POLARITY, R-FLAG-SETUP-HIGH), each shown
// both ways on a virtual time line, and the default twin against the ideal.

#include <gtest/gtest.h>

#include <memory>

#include "lec6/lec/memory_map.hpp"
#include "lec6/sim/controller.hpp"
#include "lec6/twin/field_profile.hpp"
#include "test_time.hpp"

namespace lec6::sim {
namespace {

using lec::Coil;
using lec::StatusFlags;
using std::chrono::milliseconds;

using testing::ms;

lec::StepData assumed_step(int32_t pos_001mm) {
  lec::StepData s;
  s.movement_mode = lec::MovementMode::Absolute;
  s.speed_mm_s = 200;
  s.position_001mm = pos_001mm;
  s.acceleration_mm_s2 = 1000;
  s.deceleration_mm_s2 = 1000;
  s.pushing_speed_mm_s = 20;
  s.moving_force_pct = 100;
  s.in_position_001mm = 100;
  return s;
}

class Assumptions : public ::testing::Test {
 protected:
  // A controller powered on at `initial_mm`, serial mode, servo ready (not homed).
  void make(ActuatorConfig cfg, double initial_mm = 10.0) {
    cfg.initial_position_mm = initial_mm;
    c = std::make_unique<Controller>(cfg, t);
    coil(Coil::SerialMode, true);
    coil(Coil::SVON, true);
    t += ms(100);
  }
  void coil(Coil k, bool on) {
    (void)c->handle(
        modbus::WriteCoilRequest{lec::address(k), on ? modbus::kCoilOn : modbus::kCoilOff}, t);
  }
  void direct(const lec::StepData& d) {
    const auto regs = d.to_registers();
    (void)c->handle(modbus::WriteRegistersRequest::of(lec::kDirectData, regs), t);
    const uint16_t go[] = {lec::kDirectStartValue};
    (void)c->handle(modbus::WriteRegistersRequest::of(lec::kDirectStart, go), t);
  }
  // Polls every 10 ms until `done` or `limit`; returns the time it took.
  template <typename F>
  Duration until(F done, Duration limit) {
    const TimePoint from = t;
    while (t - from < limit) {
      if (done(c->status(t))) break;
      t += ms(10);
    }
    return t - from;
  }
  void home() {
    coil(Coil::SETUP, true);
    until([](StatusFlags f) { return f.seton() && !f.busy(); }, std::chrono::seconds(60));
    coil(Coil::SETUP, false);
  }
  StatusFlags flags() { return c->status(t); }

  TimePoint t = TimePoint{} + ms(10'000);
  std::unique_ptr<Controller> c;
};

// A driver's cold start from mid-stroke allows ~10 s for SETON (issue 33).
TEST_F(Assumptions, HomingSpeedDecidesAColdStartFromMidStroke) {
  ActuatorConfig ideal = ideal_config();
  ideal.stroke_max_mm = 450;
  make(ideal, 450.0);
  coil(Coil::SETUP, true);
  const Duration slow =
      until([](StatusFlags f) { return f.seton() && !f.busy(); }, std::chrono::seconds(60));
  EXPECT_GT(slow, std::chrono::seconds(20)) << "450 mm at 20 mm/s";

  ActuatorConfig def = default_config();
  def.stroke_max_mm = 450;
  make(def, 450.0);
  coil(Coil::SETUP, true);
  const Duration fast =
      until([](StatusFlags f) { return f.seton() && !f.busy(); }, std::chrono::seconds(60));
  EXPECT_LT(fast, std::chrono::seconds(10)) << "the default twin homes within a driver's 10 s";
}

TEST_F(Assumptions, HomingDirectionSeeksTheOtherEndFirst) {
  ActuatorConfig cfg = ideal_config();
  cfg.homing_direction = ActuatorConfig::HomingDirection::MaxEnd;
  cfg.origin_speed_mm_s = 100;
  make(cfg, 300.0);
  coil(Coil::SETUP, true);
  t += ms(900);  // 100 mm toward 400 at 100 mm/s, then back
  EXPECT_GT(c->physical(t).position, 340.0) << "heading for the max end first";
  const Duration rest =
      until([](StatusFlags f) { return f.seton() && !f.busy(); }, std::chrono::seconds(60));
  EXPECT_GT(ms(900) + rest, std::chrono::seconds(4)) << "100 mm up, then 400 mm down";
  EXPECT_NEAR(c->physical(t).position, 0.0, 1e-6);
}

TEST_F(Assumptions, SetonOnARehomeIsKeptOrCleared) {
  for (auto mode : {ActuatorConfig::SetonOnRehome::Keep, ActuatorConfig::SetonOnRehome::Clear}) {
    ActuatorConfig cfg = ideal_config();
    cfg.seton_on_rehome = mode;
    make(cfg, 10.0);
    home();
    direct(assumed_step(20000));
    t += std::chrono::seconds(2);
    coil(Coil::SETUP, true);
    t += ms(10);
    ASSERT_TRUE(flags().busy());
    EXPECT_EQ(flags().seton(), mode == ActuatorConfig::SetonOnRehome::Keep);
    until([](StatusFlags f) { return f.seton() && !f.busy(); }, std::chrono::seconds(60));
    EXPECT_TRUE(flags().seton());
    EXPECT_EQ(c->state(t).position_001mm, 0);
  }
}

TEST_F(Assumptions, ResetCancelsHomingOrNot) {
  for (bool cancels : {true, false}) {
    ActuatorConfig cfg = ideal_config();
    cfg.reset_cancels_homing = cancels;
    make(cfg, 200.0);
    coil(Coil::SETUP, true);
    t += ms(500);
    coil(Coil::RESET, true);
    coil(Coil::RESET, false);
    t += ms(100);
    EXPECT_EQ(flags().busy(), !cancels) << "reset_cancels_homing " << cancels;
    t += std::chrono::seconds(20);
    EXPECT_EQ(flags().seton(), !cancels);
  }
}

// A stream of retargets: re-planned, the carriage never stops between them;
// stop-then-start, it comes to rest before each new start.
TEST_F(Assumptions, RetargetReplansOrStopsFirst) {
  for (auto mode : {ActuatorConfig::Retarget::Replan, ActuatorConfig::Retarget::StopThenStart}) {
    ActuatorConfig cfg = ideal_config();
    cfg.retarget = mode;
    make(cfg, 10.0);
    home();
    direct(assumed_step(30000));
    t += ms(600);  // cruising at 200 mm/s
    ASSERT_NEAR(c->physical(t).velocity, 200.0, 1e-6);
    double slowest = 1e9;
    for (int i = 1; i <= 5; ++i) {
      direct(assumed_step(30000 + i * 1000));
      for (int k = 0; k < 10; ++k) {  // a retarget every 100 ms
        t += ms(10);
        slowest = std::min(slowest, std::abs(c->physical(t).velocity));
      }
    }
    if (mode == ActuatorConfig::Retarget::Replan) {
      EXPECT_NEAR(slowest, 200.0, 1e-6) << "re-planned: never slowed";
    } else {
      EXPECT_LT(slowest, 1.0) << "stop-then-start: at rest before each start";
    }
    t += std::chrono::seconds(3);
    EXPECT_EQ(c->state(t).position_001mm, 35000);
    EXPECT_TRUE(flags().inp());
  }
}

TEST_F(Assumptions, AlarmPolarityInvertsX4FOnly) {
  ActuatorConfig cfg = ideal_config();
  cfg.alarm_polarity = ActuatorConfig::AlarmPolarity::ActiveLow;
  make(cfg, 10.0);
  EXPECT_TRUE(flags().alarm()) << "no alarm: X4F = 1 on an inverted controller";
  direct(assumed_step(10000));  // ABS before homing: alarm 99
  EXPECT_FALSE(flags().alarm()) << "alarm present: X4F = 0";
  EXPECT_EQ(c->eeprom().alarms.groups[0].codes[0], lec::alarm::kNotHomed);
}

TEST_F(Assumptions, SetupLeftHighRefusesStartsOrNot) {
  for (auto mode :
       {ActuatorConfig::SetupLeftHigh::Ignored, ActuatorConfig::SetupLeftHigh::RefusesStarts}) {
    ActuatorConfig cfg = ideal_config();
    cfg.setup_left_high = mode;
    make(cfg, 10.0);
    coil(Coil::SETUP, true);  // and never cleared
    until([](StatusFlags f) { return f.seton() && !f.busy(); }, std::chrono::seconds(60));
    direct(assumed_step(5000));
    EXPECT_EQ(flags().busy(), mode == ActuatorConfig::SetupLeftHigh::Ignored);
    coil(Coil::SETUP, false);
    direct(assumed_step(5000));
    EXPECT_TRUE(flags().busy()) << "SETUP cleared: starts work";
  }
}

TEST(DefaultTwin, FollowsTheFieldWhereTheEvidenceIsStrong) {
  const ActuatorConfig d = default_config();
  EXPECT_EQ(d.busy_delay, milliseconds(20));
  EXPECT_EQ(d.busy_min, milliseconds(60));
  EXPECT_EQ(d.origin_speed_mm_s, 50.0);
  EXPECT_EQ(d.seton_on_rehome, ActuatorConfig::SetonOnRehome::Clear);
  // Kept as the manual says (the evidence against it is weaker; decisions page).
  EXPECT_EQ(d.alarm_polarity, ActuatorConfig::AlarmPolarity::ActiveHigh);
  EXPECT_TRUE(d.reset_cancels_homing);
  EXPECT_EQ(d.retarget, ActuatorConfig::Retarget::Replan);
  EXPECT_EQ(d.setup_left_high, ActuatorConfig::SetupLeftHigh::Ignored);
  const ActuatorConfig i = ideal_config();
  EXPECT_EQ(i.busy_delay, Duration::zero());
  EXPECT_EQ(i.origin_speed_mm_s, 20.0);
  EXPECT_EQ(i.seton_on_rehome, ActuatorConfig::SetonOnRehome::Keep);
}

TEST(AssumptionKeys, EveryAssumptionIsAProfileKey) {
  const auto p = twin::parse_field_profile(
      "actuator:\n"
      "  origin_speed_mm_s: 45\n"
      "  homing_direction: max_end\n"
      "  seton_on_rehome: clear\n"
      "  reset_cancels_homing: false\n"
      "  retarget: stop_then_start\n"
      "  alarm_polarity: active-low\n"
      "  setup_left_high: refuses_starts\n"
      "  busy_delay_ms: 20\n"
      "  busy_min_ms: 60\n",
      "a.yaml");
  EXPECT_EQ(p.actuator.origin_speed_mm_s, 45.0);
  EXPECT_EQ(p.actuator.homing_direction, ActuatorConfig::HomingDirection::MaxEnd);
  EXPECT_EQ(p.actuator.seton_on_rehome, ActuatorConfig::SetonOnRehome::Clear);
  EXPECT_FALSE(p.actuator.reset_cancels_homing);
  EXPECT_EQ(p.actuator.retarget, ActuatorConfig::Retarget::StopThenStart);
  EXPECT_EQ(p.actuator.alarm_polarity, ActuatorConfig::AlarmPolarity::ActiveLow);
  EXPECT_EQ(p.actuator.setup_left_high, ActuatorConfig::SetupLeftHigh::RefusesStarts);
  try {
    (void)twin::parse_field_profile("actuator:\n  retarget: jump\n", "b.yaml");
    FAIL() << "a value outside the choices was taken";
  } catch (const twin::ProfileError& e) {
    EXPECT_STREQ(e.what(), "b.yaml:2: actuator.retarget: 'jump' is not replan or stop_then_start");
  }
}

}  // namespace
}  // namespace lec6::sim
