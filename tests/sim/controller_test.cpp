// The controller model on a virtual time line: flags at the analytic
// instants, alarms, pushing, hold/reset/servo/estop, registers.
// Over 450 lines: the controller's state machine case by case (one per
// manual sequence and alarm), on one time line fixture.

#include "lec6/sim/controller.hpp"

#include <gtest/gtest.h>

#include <memory>
#include <vector>

#include "lec6/error.hpp"
#include "lec6/lec/memory_map.hpp"

#include "test_time.hpp"

namespace lec6::sim {
namespace {

using lec::Coil;
using lec::StatusFlags;
using lec::StepData;
using modbus::ExceptionCode;

using testing::ms;

std::optional<ExceptionCode> exception_of(const modbus::Response& r) {
  if (auto* e = std::get_if<modbus::ExceptionResponse>(&r)) return e->code;
  return std::nullopt;
}

StepData positioning(int32_t pos_001mm, uint16_t speed = 500, uint16_t accel = 5000) {
  StepData s;
  s.movement_mode = lec::MovementMode::Absolute;
  s.speed_mm_s = speed;
  s.position_001mm = pos_001mm;
  s.acceleration_mm_s2 = accel;
  s.deceleration_mm_s2 = accel;
  s.pushing_speed_mm_s = 20;
  s.moving_force_pct = 100;
  s.in_position_001mm = 100;
  return s;
}

StepData pushing(int32_t start_001mm, int32_t distance_001mm) {
  StepData s = positioning(start_001mm);
  s.pushing_force_pct = 50;
  s.trigger_level_pct = 30;
  s.pushing_speed_mm_s = 20;
  s.in_position_001mm = distance_001mm;
  return s;
}

class Twin : public ::testing::Test {
 protected:
  void make(const ActuatorConfig& cfg = {}) { c = std::make_unique<Controller>(cfg, t); }
  void SetUp() override { make(); }

  modbus::Response send(const modbus::Request& r) { return c->handle(r, t); }
  void coil(Coil k, bool on) {
    auto r =
        send(modbus::WriteCoilRequest{lec::address(k), on ? modbus::kCoilOn : modbus::kCoilOff});
    ASSERT_FALSE(exception_of(r));
  }
  void pulse(Coil k) {
    coil(k, true);
    coil(k, false);
  }
  void regs(uint16_t start, std::span<const uint16_t> v) {
    auto r = send(modbus::WriteRegistersRequest::of(start, v));
    ASSERT_FALSE(exception_of(r));
  }
  void regs(uint16_t start, std::initializer_list<uint16_t> v) {
    regs(start, std::span<const uint16_t>(v.begin(), v.size()));
  }
  std::vector<uint16_t> read(uint16_t start, uint16_t count) {
    auto r = send(modbus::ReadRegistersRequest{start, count});
    return std::get<modbus::ReadRegistersResponse>(r).values;
  }
  void wait(Duration d) { t += d; }
  StatusFlags flags() { return c->status(t); }
  StatusFlags flags_at(Duration since) { return c->status(start + since); }
  lec::StateData state() { return c->state(t); }

  void servo_on() {
    coil(Coil::SerialMode, true);
    coil(Coil::SVON, true);
    wait(ms(50));
  }
  void ready() {
    servo_on();
    coil(Coil::SETUP, true);
    wait(ms(600));
    coil(Coil::SETUP, false);
    ASSERT_EQ(flags().bits, 0x0E00);
  }
  void direct(const StepData& d) {
    regs(lec::kDirectData, d.to_registers());
    regs(lec::kDirectStart, {lec::kDirectStartValue});
    start = t;
  }
  void step(unsigned n, const StepData& d) { regs(lec::step_address(n), d.to_registers()); }
  void drive(unsigned n) {
    const bool bits[8] = {bool(n & 1), bool(n & 2),  bool(n & 4),
                          bool(n & 8), bool(n & 16), bool(n & 32)};
    ASSERT_FALSE(exception_of(send(modbus::WriteCoilsRequest::of(0x10, bits))));
    coil(Coil::DRIVE, true);
    start = t;
    coil(Coil::DRIVE, false);
  }

  TimePoint t = TimePoint{} + ms(10'000);
  TimePoint start = t;
  std::unique_ptr<Controller> c;
};

TEST_F(Twin, PowerOnFlagsAndSvreDelay) {
  EXPECT_EQ(flags().bits, 0);
  coil(Coil::SerialMode, true);
  coil(Coil::SVON, true);
  const TimePoint on = t;
  EXPECT_FALSE(c->status(on + ms(49.999)).svre());
  EXPECT_TRUE(c->status(on + ms(50)).svre());
  // Manual §4.1.3: only SVRE.
  EXPECT_EQ(c->status(on + ms(50)).bits, 0x0200);
  EXPECT_EQ(c->control().y10_1f, 1u << 9);
}

TEST_F(Twin, HomingFromPowerOnPosition) {
  servo_on();
  EXPECT_EQ(state().position_001mm, 0);  // counts from where it stood (10 mm)
  coil(Coil::SETUP, true);
  start = t;
  EXPECT_TRUE(flags().busy());
  EXPECT_FALSE(flags().seton());
  // 10 mm toward the min end at 20 mm/s, 1000 mm/s²: 0.52 s.
  EXPECT_TRUE(flags_at(ms(519.9)).busy());
  EXPECT_LT(c->position_mm(start + ms(519.9)), 0.0);
  const auto done = flags_at(ms(520.1));
  EXPECT_EQ(done.bits, 0x0E00);  // manual §4.2.2: SVRE, SETON, INP
  EXPECT_EQ(c->state(start + ms(520.1)).position_001mm, 0);
  EXPECT_EQ(c->physical(start + ms(520.1)).position, 0.0);
}

TEST_F(Twin, HomingNeedsSvre) {
  coil(Coil::SerialMode, true);
  coil(Coil::SETUP, true);
  wait(ms(2000));
  EXPECT_EQ(flags().bits, 0);
}

TEST_F(Twin, BusyInpAreaAtAnalyticInstants) {
  ready();
  // INP is 1 from homing; the start clears it and raises BUSY before the reply.
  StepData d = positioning(30000);
  d.area1_001mm = 20000;  // either order
  d.area2_001mm = 10000;
  direct(d);
  EXPECT_TRUE(flags().busy());
  EXPECT_FALSE(flags().inp());
  EXPECT_FALSE(flags().area());
  // 0 → 300 mm at 500 mm/s, 5000 mm/s²: 100 mm at 0.25 s, 200 mm at 0.45 s, end 0.7 s.
  EXPECT_FALSE(flags_at(ms(249.99)).area());
  EXPECT_TRUE(flags_at(ms(250.01)).area());
  EXPECT_TRUE(flags_at(ms(449.99)).area());
  EXPECT_FALSE(flags_at(ms(450.01)).area());
  const auto before = flags_at(ms(699.99));
  EXPECT_TRUE(before.busy());
  EXPECT_FALSE(before.inp());
  const auto after = flags_at(ms(700.01));
  EXPECT_FALSE(after.busy());
  EXPECT_TRUE(after.inp());
  EXPECT_EQ(after.out(), 0);
  EXPECT_EQ(c->state(start + ms(700.01)).position_001mm, 30000);
  EXPECT_EQ(c->next_event(), std::nullopt);
}

TEST_F(Twin, StateAreaDuringMove) {
  ready();
  direct(positioning(30000));
  // Time only moves forward: query in order.
  EXPECT_EQ(c->state(start + ms(50)).thrust_pct, 35);  // friction 10 % + 50 % × 5000 / 10000
  const auto s = c->state(start + ms(350));
  EXPECT_EQ(s.position_001mm, 15000);
  EXPECT_EQ(s.speed_mm_s, 500);
  EXPECT_EQ(s.thrust_pct, 10);  // friction share while cruising
  EXPECT_EQ(s.target_001mm, 30000);
  EXPECT_EQ(s.step_no, 0);
  // Registers read the same state.
  t = start + ms(350);
  const auto regs_now = c->state(t).to_registers();
  EXPECT_EQ(read(0x9000, 7), std::vector<uint16_t>(regs_now.begin(), regs_now.end()));
  EXPECT_EQ(c->state(start + ms(800)).thrust_pct, 0);  // at rest
  // Moving force caps the thrust while positioning.
  StepData weak = positioning(0);
  weak.moving_force_pct = 20;
  t = start + ms(800);
  direct(weak);
  EXPECT_EQ(c->state(start + ms(50)).thrust_pct, 20);
}

TEST_F(Twin, StepDriveShowsOutAndStepNumber) {
  ready();
  step(5, positioning(5000));
  drive(5);
  EXPECT_TRUE(flags().busy());
  EXPECT_EQ(flags().out(), 5);
  wait(ms(1000));
  EXPECT_EQ(flags().bits, 0x0E00 | 5);
  EXPECT_EQ(state().step_no, 5);
  EXPECT_EQ(state().position_001mm, 5000);
  EXPECT_EQ(state().target_001mm, 5000);
}

TEST_F(Twin, IncrementalTargetsAddToPreviousTarget) {
  ready();
  StepData inc = positioning(5000);
  inc.movement_mode = lec::MovementMode::Incremental;
  step(2, inc);
  drive(2);
  wait(ms(1000));
  drive(2);
  wait(ms(1000));
  EXPECT_EQ(state().target_001mm, 10000);
  EXPECT_EQ(state().position_001mm, 10000);
  EXPECT_TRUE(flags().inp());
}

TEST_F(Twin, IncrementalBeforeHomingCountsFromPowerOn) {
  servo_on();
  StepData inc = positioning(500);
  inc.movement_mode = lec::MovementMode::Incremental;
  direct(inc);
  wait(ms(1000));
  EXPECT_FALSE(flags().alarm());
  EXPECT_EQ(state().position_001mm, 500);
  EXPECT_NEAR(c->physical(t).position, 15.0, 1e-9);
}

TEST_F(Twin, NewDirectStartWhileBusyRetargets) {
  ready();
  direct(positioning(30000));
  t = start + ms(300);  // at 125 mm, 500 mm/s
  direct(positioning(10000));
  EXPECT_TRUE(flags().busy());
  EXPECT_EQ(state().target_001mm, 10000);
  wait(ms(2000));
  EXPECT_EQ(state().position_001mm, 10000);
  EXPECT_TRUE(flags().inp());
  EXPECT_FALSE(flags().busy());
}

TEST_F(Twin, HoldSuspendsAndResumes) {
  ready();
  direct(positioning(30000));
  t = start + ms(300);
  coil(Coil::HOLD, true);  // at 125 mm, 500 mm/s: 25 mm to stop
  t = start + ms(500);
  EXPECT_TRUE(flags().busy());
  EXPECT_FALSE(flags().inp());
  EXPECT_EQ(state().position_001mm, 15000);
  EXPECT_EQ(state().speed_mm_s, 0);
  coil(Coil::HOLD, false);  // 150 → 300 mm from rest: 0.4 s
  EXPECT_TRUE(flags_at(ms(899.9)).busy());
  const auto f = flags_at(ms(900.1));
  EXPECT_FALSE(f.busy());
  EXPECT_TRUE(f.inp());
  EXPECT_EQ(c->state(start + ms(900.1)).position_001mm, 30000);
}

TEST_F(Twin, ResetWithoutAlarmStopsWithDeceleration) {
  ready();
  direct(positioning(30000));
  t = start + ms(300);
  pulse(Coil::RESET);
  EXPECT_FALSE(flags().busy());
  EXPECT_FALSE(flags().inp());
  EXPECT_GT(state().speed_mm_s, 0);
  t = start + ms(450);
  EXPECT_EQ(state().position_001mm, 15000);
  EXPECT_EQ(state().speed_mm_s, 0);
}

TEST_F(Twin, ServoOffStopsAtOnce) {
  ready();
  direct(positioning(30000));
  t = start + ms(300);
  coil(Coil::SVON, false);
  EXPECT_FALSE(flags().svre());
  EXPECT_FALSE(flags().busy());
  t = start + ms(900);
  EXPECT_EQ(state().position_001mm, 12500);
  EXPECT_TRUE(flags().seton());
  // A start with the servo off raises alarm 98.
  direct(positioning(0));
  EXPECT_TRUE(flags().alarm());
  EXPECT_EQ(c->alarm(), 98);
}

TEST_F(Twin, EstopAndRelease) {
  ready();
  direct(positioning(30000));
  t = start + ms(300);
  c->set_estop(true, t);
  auto f = flags();
  EXPECT_TRUE(f.estop());
  EXPECT_FALSE(f.svre());
  EXPECT_FALSE(f.busy());
  wait(ms(100));
  coil(Coil::SVON, true);  // refused while the stop is active
  wait(ms(100));
  EXPECT_FALSE(flags().svre());
  c->set_estop(false, t);
  wait(ms(100));
  EXPECT_FALSE(flags().estop());
  EXPECT_FALSE(flags().svre());  // needs SVON again
  coil(Coil::SVON, true);        // Y19 is already 1: the write itself counts
  wait(ms(49));
  EXPECT_FALSE(flags().svre());
  wait(ms(1));
  EXPECT_TRUE(flags().svre());
}

TEST_F(Twin, JogMovesWhileHeldAndStopsWithDeceleration) {
  ready();
  coil(Coil::JOG_PLUS, true);
  start = t;
  EXPECT_TRUE(flags().busy());
  t = start + ms(1000);  // 1.25 mm accelerating + 47.5 mm at 50 mm/s
  EXPECT_NEAR(c->position_mm(t), 48.75, 1e-6);
  coil(Coil::JOG_PLUS, false);  // 1.25 mm to stop at 1000 mm/s²
  EXPECT_TRUE(flags_at(ms(1049.9)).busy());
  EXPECT_FALSE(flags_at(ms(1050.1)).busy());
  EXPECT_EQ(c->state(start + ms(1050.1)).position_001mm, 5000);
  EXPECT_FALSE(flags().inp());
  // The stroke end stops a jog.
  coil(Coil::JOG_PLUS, true);
  wait(ms(20'000));
  EXPECT_EQ(state().position_001mm, 40000);
  EXPECT_FALSE(flags().busy());
  coil(Coil::JOG_PLUS, false);
  coil(Coil::JOG_MINUS, true);
  wait(ms(100));
  EXPECT_TRUE(flags().busy());
  EXPECT_LT(c->position_mm(t), 400.0);
}

TEST_F(Twin, PushingMeetsWorkpiece) {
  ActuatorConfig cfg;
  cfg.workpiece_mm = 200.0;
  make(cfg);
  ready();
  // Approach 0 → 150 mm (0.4 s), then push from rest at 20 mm/s toward 250 mm:
  // 5000 mm/s² reaches 20 mm/s in 4 ms (0.04 mm), the workpiece at 200 mm is
  // met 0.004 + 49.96 / 20 = 2.502 s later.
  direct(pushing(15000, 10000));
  EXPECT_TRUE(flags_at(ms(2901.9)).busy());
  EXPECT_FALSE(flags_at(ms(2901.9)).inp());
  const auto f = flags_at(ms(2902.1));
  EXPECT_FALSE(f.busy());
  EXPECT_TRUE(f.inp());
  const auto s = c->state(start + ms(2902.1));
  EXPECT_EQ(s.position_001mm, 20000);
  EXPECT_EQ(s.thrust_pct, 50);
  EXPECT_EQ(s.speed_mm_s, 0);
  // Keeps pushing.
  t = start + ms(10'000);
  EXPECT_EQ(state().thrust_pct, 50);
  EXPECT_TRUE(flags().inp());
  // Moving away is free; positioning back into the workpiece stalls.
  direct(positioning(10000));
  wait(ms(1000));
  EXPECT_EQ(state().position_001mm, 10000);
  EXPECT_EQ(state().thrust_pct, 0);
}

TEST_F(Twin, LeavingTheWorkpieceAndComingBackStalls) {
  ActuatorConfig cfg;
  cfg.workpiece_mm = 200.0;
  make(cfg);
  ready();
  direct(pushing(15000, 10000));
  wait(ms(5000));
  ASSERT_TRUE(flags().inp());
  direct(positioning(10000));  // away from the workpiece
  t = start + ms(20);          // 1 mm away, 100 mm/s
  EXPECT_NEAR(c->position_mm(t), 199.0, 1e-6);
  direct(positioning(30000));  // brakes, turns, runs into it again
  wait(ms(500));
  EXPECT_EQ(state().position_001mm, 20000);
  EXPECT_TRUE(flags().busy());
  wait(ms(1000));
  EXPECT_TRUE(flags().alarm());
  EXPECT_EQ(c->alarm(), 149);
}

TEST_F(Twin, PushingMissed) {
  ready();
  // No workpiece: push 50 mm from 150 mm, ends at 200 mm after 2.504 s.
  direct(pushing(15000, 5000));
  EXPECT_TRUE(flags_at(ms(2903.9)).busy());
  const auto f = flags_at(ms(2904.1));
  EXPECT_FALSE(f.busy());
  EXPECT_FALSE(f.inp());
  EXPECT_EQ(c->state(start + ms(2904.1)).position_001mm, 20000);
}

TEST_F(Twin, PositioningIntoWorkpieceStallsThenAlarm149) {
  ActuatorConfig cfg;
  cfg.workpiece_mm = 200.0;
  make(cfg);
  ready();
  direct(positioning(30000));  // meets 200 mm at 0.45 s
  const auto stalled = flags_at(ms(500));
  EXPECT_TRUE(stalled.busy());
  EXPECT_FALSE(stalled.alarm());
  EXPECT_EQ(c->state(start + ms(500)).position_001mm, 20000);
  EXPECT_EQ(c->state(start + ms(500)).thrust_pct, 100);
  EXPECT_FALSE(flags_at(ms(1449.9)).alarm());
  const auto alarmed = flags_at(ms(1450.1));
  EXPECT_TRUE(alarmed.alarm());
  EXPECT_FALSE(alarmed.busy());
  EXPECT_EQ(c->alarm(), 149);
  t = start + ms(2000);
  pulse(Coil::RESET);  // 149 needs the servo off
  EXPECT_TRUE(flags().alarm());
  coil(Coil::SVON, false);
  pulse(Coil::RESET);
  EXPECT_FALSE(flags().alarm());
}

TEST_F(Twin, HomingIntoWorkpieceRaises97) {
  ActuatorConfig cfg;
  cfg.workpiece_mm = 5.0;
  make(cfg);
  servo_on();
  coil(Coil::SETUP, true);
  start = t;
  // 10 → 5 mm: 0.02 s accelerating (0.2 mm), then 4.8 mm at 20 mm/s: 0.26 s.
  EXPECT_TRUE(flags_at(ms(300)).busy());
  EXPECT_FALSE(flags_at(ms(1259.9)).alarm());
  EXPECT_TRUE(flags_at(ms(1260.1)).alarm());
  EXPECT_EQ(c->alarm(), 97);
  EXPECT_FALSE(flags().seton());
}

TEST_F(Twin, AlarmsRefuseMotionAndShiftHistory) {
  ready();
  step(3, positioning(50000));  // 500 mm: beyond the 400 mm stroke
  drive(3);
  EXPECT_TRUE(flags().alarm());
  EXPECT_FALSE(flags().busy());
  EXPECT_FALSE(flags().inp());
  EXPECT_EQ(c->alarm(), 52);
  wait(ms(1000));
  EXPECT_EQ(state().position_001mm, 0);  // nothing moved
  EXPECT_EQ(read(0x0380, 1)[0], 0x3400);

  // Refused while the alarm is present, with no new alarm.
  step(4, positioning(1000));
  drive(4);
  EXPECT_FALSE(flags().busy());
  EXPECT_EQ(read(0x0384, 1)[0], 0);

  pulse(Coil::RESET);
  EXPECT_FALSE(flags().alarm());
  drive(7);  // blank step
  EXPECT_EQ(c->alarm(), 51);
  EXPECT_EQ(read(0x0380, 8), (std::vector<uint16_t>{0x3300, 0, 0, 0, 0x3400, 0, 0, 0}));
  pulse(Coil::RESET);

  direct(positioning(-100));  // direct operation beyond the stroke: 62
  EXPECT_EQ(c->alarm(), 62);
  pulse(Coil::RESET);

  StepData bad = positioning(1000);
  bad.speed_mm_s = 0;  // out of range
  direct(bad);
  EXPECT_EQ(c->alarm(), 48);
  pulse(Coil::RESET);

  StepData trig = pushing(1000, 100);
  trig.trigger_level_pct = 80;  // above the pushing force
  step(9, trig);
  drive(9);
  EXPECT_EQ(c->alarm(), 48);
  pulse(Coil::RESET);

  EXPECT_EQ(c->eeprom().alarms.groups[0].codes[0], 48);
  EXPECT_EQ(c->eeprom().alarms.groups[1].codes[0], 48);
  EXPECT_EQ(c->eeprom().alarms.groups[2].codes[0], 62);
  EXPECT_EQ(c->eeprom().alarms.groups[3].codes[0], 51);
  EXPECT_EQ(c->eeprom().alarms.groups[4].codes[0], 52);

  // After RESET motion works again.
  step(4, positioning(1000));
  drive(4);
  EXPECT_TRUE(flags().busy());
}

TEST_F(Twin, HistoryKeepsSixteenGroups) {
  servo_on();
  for (int i = 0; i < 20; ++i) {
    drive(1);  // blank: 51
    pulse(Coil::RESET);
  }
  for (const auto& g : c->eeprom().alarms.groups) EXPECT_EQ(g.codes[0], 51);
}

TEST_F(Twin, StartAlarmsServoOffAndNotHomed) {
  coil(Coil::SerialMode, true);
  step(1, positioning(1000));
  drive(1);
  EXPECT_EQ(c->alarm(), 98);
  pulse(Coil::RESET);
  coil(Coil::SVON, true);
  wait(ms(50));
  drive(1);  // ABS before homing
  EXPECT_EQ(c->alarm(), 99);
}

TEST_F(Twin, WareaSetting) {
  ActuatorConfig cfg;
  cfg.warea_mm = RangeMm{100.0, 200.0};
  make(cfg);
  ready();
  EXPECT_FALSE(flags().warea());
  direct(positioning(15000));
  wait(ms(1000));
  EXPECT_TRUE(flags().warea());
}

TEST_F(Twin, FlagWordsAndDirectStartRegister) {
  servo_on();
  EXPECT_EQ(read(lec::kStatusWord, 1)[0], flags().bits);
  EXPECT_EQ(read(lec::kControlWordY10, 2), (std::vector<uint16_t>{1u << 9, 1}));
  // D90C1 writes Y10–Y1F as coils: SETUP via the word.
  regs(lec::kControlWordY10, {(1u << 9) | (1u << 12)});
  EXPECT_TRUE(flags().busy());
  wait(ms(1000));
  EXPECT_TRUE(flags().seton());
  regs(lec::kControlWordY10, {1u << 9});
  direct(positioning(1000));
  EXPECT_EQ(read(lec::kDirectStart, 2), (std::vector<uint16_t>{0, 0}));  // processed: reads 0
  const auto d = positioning(1000).to_registers();
  EXPECT_EQ(read(lec::kDirectData, 16), std::vector<uint16_t>(d.begin(), d.end()));
  // D9100 ← 0x1000 (another driver's value) also starts.
  wait(ms(1000));
  regs(lec::kDirectData + 2, {0, 2000});
  regs(lec::kDirectStart, {0x1000});
  EXPECT_TRUE(flags().busy());
  // Undefined addresses inside an area read 0.
  EXPECT_EQ(read(0x9010, 2), (std::vector<uint16_t>{0, 0}));
}

TEST_F(Twin, StartAndDataCannotShareOneWrite) {
  // D9101 is undefined and refuses writes (digest §4), so one FC10 over
  // D9100–D9111 is refused as a whole (02) and nothing starts.
  ready();
  std::vector<uint16_t> all = {lec::kDirectStartValue, 0};
  const auto d = positioning(4000).to_registers();
  all.insert(all.end(), d.begin(), d.end());
  const auto r = send(modbus::WriteRegistersRequest::of(lec::kDirectStart, all));
  EXPECT_EQ(exception_of(r), ExceptionCode::IllegalAddress);
  EXPECT_FALSE(flags().busy());
  EXPECT_EQ(read(lec::kDirectData, 1)[0], 0);
}

TEST_F(Twin, BackToParallelModeClearsInputs) {
  servo_on();
  EXPECT_TRUE(flags().svre());
  coil(Coil::SerialMode, false);
  EXPECT_FALSE(flags().svre());
  EXPECT_EQ(c->control().y10_1f, 0);
  EXPECT_FALSE(c->control().serial_mode);
}

TEST_F(Twin, StepWriteCountersAndName) {
  StepData s = positioning(1000);
  step(1, s);
  step(1, s);
  // One FC10 spanning the end of step 1 and the start of step 2 counts once for each.
  regs(lec::step_address(1) + 14, {0, 100, 1, 500});
  EXPECT_EQ(c->eeprom().step_writes[1], 3u);
  EXPECT_EQ(c->eeprom().step_writes[2], 1u);
  EXPECT_EQ(c->eeprom().step_writes[0], 0u);
  EXPECT_EQ(c->eeprom().steps[2].movement_mode, lec::MovementMode::Absolute);
  EXPECT_EQ(c->eeprom().steps[2].speed_mm_s, 500);
  const uint64_t g = c->eeprom_generation();
  regs(lec::kDirectData, {1});
  EXPECT_EQ(c->eeprom_generation(), g);  // RAM, not EEPROM
  const auto name = read(lec::kEquipmentName, 8);
  EXPECT_EQ(lec::EquipmentName::from_registers(name).text, "LEC6-TWIN");
  EXPECT_EQ(name[0], ('L' << 8) | 'E');
  EXPECT_EQ(name[7], 0);
}

TEST_F(Twin, RefusesWhatTheMapRefuses) {
  EXPECT_EQ(exception_of(send(modbus::WriteCoilRequest{0x19, modbus::kCoilOn})),
            ExceptionCode::IllegalAddress);
  EXPECT_EQ(exception_of(send(modbus::ReadRegistersRequest{0x9000, 0})),
            ExceptionCode::IllegalAccessRange);
  EXPECT_FALSE(exception_of(send(modbus::WriteCoilRequest{0x30, modbus::kCoilOn})));
  EXPECT_FALSE(exception_of(send(modbus::WriteCoilRequest{0x19, modbus::kCoilOn})));
}

TEST(ActuatorConfig, ValidateRefusesNonsense) {
  EXPECT_TRUE(validate(ActuatorConfig{}).empty());
  ActuatorConfig c;
  c.stroke_min_mm = 10;
  c.equipment_name = "a name that is far too long";
  c.max_speed_mm_s = 0;
  EXPECT_EQ(validate(c).size(), 3u);
  EXPECT_THROW(Controller(c, TimePoint{}), lec6::InvalidArgument);
}

TEST(ActuatorConfig, NegativeStrokeMinHomesToOrigin) {
  ActuatorConfig cfg;
  cfg.stroke_min_mm = -2.0;
  Controller c(cfg, TimePoint{});
  TimePoint t{};
  for (auto [coil, on] : {std::pair{Coil::SerialMode, true}, std::pair{Coil::SVON, true}}) {
    (void)c.handle(
        modbus::WriteCoilRequest{lec::address(coil), on ? modbus::kCoilOn : modbus::kCoilOff}, t);
  }
  t += std::chrono::milliseconds(50);
  (void)c.handle(modbus::WriteCoilRequest{lec::address(Coil::SETUP), modbus::kCoilOn}, t);
  // Passes through −2 mm (the min end) before returning to 0.
  bool below = false;
  for (int i = 1; i < 200; ++i) {
    if (c.physical(t + to_duration(FractionalMilliseconds(5.0 * i))).position < -1.9) below = true;
  }
  EXPECT_TRUE(below);
  t += std::chrono::milliseconds(2000);
  EXPECT_EQ(c.status(t).bits, 0x0E00);
  EXPECT_EQ(c.state(t).position_001mm, 0);
}

}  // namespace
}  // namespace lec6::sim
