// The twin's wear (ActuatorConfig::wear_pct_per_m, issue 26): every metre
// travelled adds to thrust and takes off speed, so the same move grows
// longer and needs more thrust; without wear nothing changes.

#include <gtest/gtest.h>

#include <memory>

#include "lec6/lec/memory_map.hpp"
#include "lec6/sim/controller.hpp"

#include "test_time.hpp"

namespace lec6::sim {
namespace {

using lec::Coil;

using testing::ms;

struct Measured {
  double duration_ms = 0;
  double peak_thrust_pct = 0;
};

class Wear : public ::testing::Test {
 protected:
  void make(double wear_pct_per_m) {
    ActuatorConfig cfg;
    cfg.wear_pct_per_m = wear_pct_per_m;
    c = std::make_unique<Controller>(cfg, t);
    coil(Coil::SerialMode, true);
    coil(Coil::SVON, true);
    t += ms(50);
    coil(Coil::SETUP, true);
    t += ms(2000);
    coil(Coil::SETUP, false);
  }
  void coil(Coil k, bool on) {
    (void)c->handle(
        modbus::WriteCoilRequest{lec::address(k), on ? modbus::kCoilOn : modbus::kCoilOff}, t);
  }
  // A direct move to `mm`, followed in 1 ms steps until BUSY falls.
  Measured move(double mm) {
    lec::StepData s;
    s.movement_mode = lec::MovementMode::Absolute;
    s.speed_mm_s = 200;
    s.position_001mm = static_cast<int32_t>(mm * 100);
    s.acceleration_mm_s2 = 2000;
    s.deceleration_mm_s2 = 2000;
    s.pushing_speed_mm_s = 20;
    s.moving_force_pct = 100;
    s.in_position_001mm = 50;
    const auto regs = s.to_registers();
    (void)c->handle(modbus::WriteRegistersRequest::of(lec::kDirectData, regs), t);
    const uint16_t go[] = {lec::kDirectStartValue};
    (void)c->handle(modbus::WriteRegistersRequest::of(lec::kDirectStart, go), t);
    Measured m;
    const TimePoint start = t;
    while (c->status(t).busy()) {
      m.peak_thrust_pct = std::max(m.peak_thrust_pct, c->thrust_pct(t));
      t += ms(1);
      if (t - start > std::chrono::seconds(60)) break;
    }
    m.duration_ms = to_seconds(t - start) * 1000;
    return m;
  }

  TimePoint t = TimePoint{} + ms(10'000);
  std::unique_ptr<Controller> c;
};

TEST_F(Wear, TenPercentPerMetreAddsAboutTenPercentAfterAMetre) {
  make(10.0);
  (void)move(50);
  const Measured first = move(300);
  (void)move(50);
  // 250 mm per move: four more moves make a metre and more.
  for (int i = 0; i < 4; ++i) (void)move(i % 2 ? 50 : 300);
  EXPECT_GT(c->travelled_m(), 1.5);
  const Measured later = move(300);
  const double wear = c->travelled_m() * 0.10;  // as the twin saw it at that start (about)
  EXPECT_GT(later.peak_thrust_pct, first.peak_thrust_pct * 1.10) << "wear " << wear;
  EXPECT_GT(later.duration_ms, first.duration_ms * 1.08);
  EXPECT_LT(later.duration_ms, first.duration_ms * 1.30);
}

TEST_F(Wear, WithoutWearTheSameMoveStaysTheSame) {
  make(0.0);
  (void)move(50);
  const Measured first = move(300);
  for (int i = 0; i < 5; ++i) (void)move(i % 2 ? 300 : 50);  // ends at 50
  const Measured later = move(300);
  EXPECT_NEAR(later.duration_ms, first.duration_ms, 1.0);
  EXPECT_DOUBLE_EQ(later.peak_thrust_pct, first.peak_thrust_pct);
}

}  // namespace
}  // namespace lec6::sim
