// The twin's field quirks (ActuatorConfig::busy_delay, busy_min,
// target_update_late) on a virtual time line, and the truth record
// (OperationRecord) the client's completion tests are judged against.

#include <gtest/gtest.h>

#include <memory>

#include "lec6/lec/memory_map.hpp"
#include "lec6/sim/controller.hpp"

#include "test_time.hpp"

namespace lec6::sim {
namespace {

using lec::Coil;
using lec::StatusFlags;

using testing::ms;

lec::StepData quirk_step(int32_t pos_001mm, lec::MovementMode mode = lec::MovementMode::Absolute) {
  lec::StepData s;
  s.movement_mode = mode;
  s.speed_mm_s = 500;
  s.position_001mm = pos_001mm;
  s.acceleration_mm_s2 = 5000;
  s.deceleration_mm_s2 = 5000;
  s.pushing_speed_mm_s = 20;
  s.moving_force_pct = 100;
  s.in_position_001mm = 100;
  return s;
}

class Quirks : public ::testing::Test {
 protected:
  void make(Duration delay, Duration min_pulse = {}, bool late = false) {
    ActuatorConfig cfg;
    cfg.busy_delay = delay;
    cfg.busy_min = min_pulse;
    cfg.target_update_late = late;
    c = std::make_unique<Controller>(cfg, t);
    coil(Coil::SerialMode, true);
    coil(Coil::SVON, true);
    t += ms(50);
    coil(Coil::SETUP, true);
    t += ms(2000);  // homing (10 mm at 20 mm/s) plus any delay
    coil(Coil::SETUP, false);
    ASSERT_EQ(flags().bits, 0x0E00) << "homed: SVRE SETON INP";
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
  void drive(unsigned n) {
    const bool bits[8] = {bool(n & 1), bool(n & 2),  bool(n & 4),
                          bool(n & 8), bool(n & 16), bool(n & 32)};
    (void)c->handle(modbus::WriteCoilsRequest::of(0x10, bits), t);
    coil(Coil::DRIVE, true);
    coil(Coil::DRIVE, false);
  }
  StatusFlags flags(Duration after = {}) { return c->status(t + after); }
  lec::StateData state(Duration after = {}) { return c->state(t + after); }

  TimePoint t = TimePoint{} + ms(10'000);
  std::unique_ptr<Controller> c;
};

TEST_F(Quirks, WithoutQuirksBusyRisesAtTheStart) {
  make({});
  direct(quirk_step(10000));
  EXPECT_TRUE(flags().busy());
  EXPECT_FALSE(flags().inp());
  EXPECT_FALSE(c->start_pending());
}

TEST_F(Quirks, StartChecksHappenWhenBusyWouldRise) {
  make(ms(20));
  drive(0);  // step 0 is blank: alarm 51, 20 ms late
  EXPECT_FALSE(flags().alarm());
  EXPECT_TRUE(flags(ms(20)).alarm());
  EXPECT_EQ(c->operations().back().refused_alarm, lec::alarm::kStepNotRegistered);
  EXPECT_FALSE(c->operations().back().busy_rose);
}

TEST_F(Quirks, BusyDelayKeepsTheOldOutputsUntilBusyRises) {
  make(ms(20));
  direct(quirk_step(10000));
  const StatusFlags during = flags(ms(19.9));
  EXPECT_FALSE(during.busy());
  EXPECT_TRUE(during.inp()) << "INP keeps the previous value";
  EXPECT_EQ(state(ms(19.9)).position_001mm, 0) << "the carriage waits";
  EXPECT_EQ(state(ms(19.9)).target_001mm, 10000) << "the target shows at once (not late)";
  EXPECT_TRUE(c->start_pending());
  const StatusFlags after = flags(ms(20));
  EXPECT_TRUE(after.busy());
  EXPECT_FALSE(after.inp());
  const auto& rec = c->operations().back();
  ASSERT_TRUE(rec.busy_rose);
  EXPECT_EQ(*rec.busy_rose - rec.taken, ms(20));
}

TEST_F(Quirks, TargetUpdateLateKeepsD9004AndD9006AndOutputs) {
  make(ms(30), {}, true);
  lec::StepData s = quirk_step(12000);
  (void)c->handle(modbus::WriteRegistersRequest::of(lec::step_address(5),
                                                    std::span<const uint16_t>(s.to_registers())),
                  t);
  drive(5);
  EXPECT_EQ(state(ms(29)).target_001mm, 0);
  EXPECT_EQ(state(ms(29)).step_no, 0);
  EXPECT_EQ(flags(ms(29)).out(), 0);
  EXPECT_EQ(state(ms(30)).target_001mm, 12000);
  EXPECT_EQ(state(ms(30)).step_no, 5);
  EXPECT_EQ(flags(ms(30)).out(), 5);
}

TEST_F(Quirks, IncCountsFromTheTargetWhenTheStartWasTaken) {
  make(ms(20));  // early target update: D9004 shows the new target during the delay
  direct(quirk_step(2500, lec::MovementMode::Incremental));
  EXPECT_EQ(state(ms(5)).target_001mm, 2500);
  t += ms(500);
  EXPECT_EQ(state().target_001mm, 2500) << "not counted twice";
  EXPECT_EQ(state().position_001mm, 2500);
}

TEST_F(Quirks, ShortestBusyPulseForAMoveAlreadyAtItsTarget) {
  make({}, ms(60));
  direct(quirk_step(0));  // already there
  EXPECT_TRUE(flags().busy());
  EXPECT_FALSE(flags(ms(59.9)).inp());
  EXPECT_TRUE(flags(ms(59.9)).busy());
  EXPECT_FALSE(flags(ms(60)).busy());
  EXPECT_TRUE(flags(ms(60)).inp());
  const auto& rec = c->operations().back();
  EXPECT_EQ(*rec.busy_fell - *rec.busy_rose, ms(60));
}

TEST_F(Quirks, WithoutTheMinimumAnAtTargetPulseHasNoLength) {
  make({});
  direct(quirk_step(0));
  EXPECT_FALSE(flags().busy());
  const auto& rec = c->operations().back();
  EXPECT_EQ(rec.busy_rose, rec.busy_fell);
}

TEST_F(Quirks, HomeWhenHomedShowsTheShortPulseToo) {
  make(ms(10), ms(60));
  coil(Coil::SETUP, true);
  EXPECT_FALSE(flags(ms(9)).busy());
  EXPECT_TRUE(flags(ms(10)).busy());
  EXPECT_TRUE(flags(ms(69)).busy());
  EXPECT_FALSE(flags(ms(70)).busy());
  EXPECT_TRUE(flags(ms(70)).seton());
}

TEST_F(Quirks, ResetCancelsAPendingStart) {
  make(ms(50));
  direct(quirk_step(20000));
  t += ms(10);
  coil(Coil::RESET, true);
  coil(Coil::RESET, false);
  t += ms(500);
  EXPECT_FALSE(flags().busy());
  EXPECT_EQ(state().position_001mm, 0);
  EXPECT_TRUE(c->operations().back().cancelled);
  EXPECT_FALSE(c->operations().back().busy_rose);
}

TEST_F(Quirks, ARetargetLetsTheRunningMoveGoOnUntilItBegins) {
  make(ms(150));
  direct(quirk_step(10000));
  t += ms(150 + 200);  // begun 200 ms ago: decelerating, 25 mm (100 ms) to go
  ASSERT_TRUE(flags().busy());
  direct(quirk_step(30000));
  // The old move ends at 100 mm inside the delay: BUSY falls, INP rises.
  const Duration old_end = ms(120);
  EXPECT_TRUE(flags(old_end).inp());
  EXPECT_FALSE(flags(old_end).busy());
  EXPECT_EQ(state(old_end).position_001mm, 10000);
  EXPECT_TRUE(flags(ms(150)).busy());
  t += ms(1500);
  EXPECT_EQ(state().position_001mm, 30000);
  const auto& recs = c->operations();
  ASSERT_GE(recs.size(), 2u);
  EXPECT_TRUE(recs[recs.size() - 2].busy_fell) << "the first move ended on its own";
  EXPECT_TRUE(recs.back().busy_fell);
}

TEST_F(Quirks, ARetargetWithoutDelaySupersedesTheRunningMove) {
  make({});
  direct(quirk_step(10000));
  t += ms(100);
  direct(quirk_step(30000));
  t += ms(1500);
  const auto& recs = c->operations();
  EXPECT_TRUE(recs[recs.size() - 2].superseded);
  EXPECT_FALSE(recs[recs.size() - 2].busy_fell);
}

TEST(QuirkConfig, RangesAreChecked) {
  ActuatorConfig cfg;
  cfg.busy_delay = ms(-1);
  EXPECT_FALSE(validate(cfg).empty());
  cfg.busy_delay = ms(20);
  cfg.busy_min = std::chrono::seconds(11);
  EXPECT_FALSE(validate(cfg).empty());
  cfg.busy_min = ms(60);
  EXPECT_TRUE(validate(cfg).empty());
}

}  // namespace
}  // namespace lec6::sim
