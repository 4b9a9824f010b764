// `lec sim --calibrate` learns homing and retarget behaviour (issue 33):
// record, on a virtual clock, a driver's cold start from mid-stroke, a
// re-home and a stream of retargets on a twin far from the ideal, and check
// that the calibration names each behaviour; on the ideal twin it names the
// ideal's.

#include <gtest/gtest.h>

#include "lec6/client/actuator.hpp"
#include "lec6/client/client.hpp"
#include "lec6/lec/memory_map.hpp"
#include "lec6/sim/bus.hpp"
#include "lec6/transport/recording_link.hpp"
#include "lec6/twin/calibrate.hpp"
#include "lec6/twin/field_profile.hpp"
#include "lec6/twin/replay.hpp"
#include "lec6/twin/sim_link.hpp"

namespace lec6::twin {
namespace {

using std::chrono::milliseconds;
using std::chrono::seconds;

lec::StepData to(int32_t pos_001mm) {
  lec::StepData s;
  s.movement_mode = lec::MovementMode::Absolute;
  s.speed_mm_s = 200;
  s.position_001mm = pos_001mm;
  s.acceleration_mm_s2 = 2000;
  s.deceleration_mm_s2 = 2000;
  s.pushing_speed_mm_s = 20;
  s.moving_force_pct = 100;
  s.in_position_001mm = 50;
  return s;
}

std::vector<Exchange> session_on(const sim::ActuatorConfig& actuator) {
  VirtualClock clock{TimePoint{} + seconds(1)};
  sim::Bus bus(sim::LineConfig{}, sim::FaultConfig{});
  bus.add(1, actuator, clock.now());
  SimLink link(bus, clock);
  const TimePoint origin = clock.now();
  std::vector<LineRecord> records;
  auto us = [&](TimePoint t) {
    return std::chrono::duration_cast<std::chrono::microseconds>(t - origin).count();
  };
  transport::RecordingLink rec(link, [&](transport::LineChunk&& c) {
    LineRecord r;
    r.kind = c.sent ? LineRecord::Kind::Query : LineRecord::Kind::Reply;
    r.t_us = us(c.start);
    r.end_us = us(c.end);
    r.bytes = std::move(c.bytes);
    r.line = records.size() + 2;
    records.push_back(std::move(r));
  });
  client::Client c(rec, {});
  client::Actuator axis(c);
  axis.set_serial_mode(true);
  axis.servo_on(axis.deadline_in(seconds(2)));
  axis.home(axis.deadline_in(seconds(60)));  // the cold start from mid-stroke
  client::DirectMove m;
  m.position_001mm = 15000;
  axis.move(m, axis.deadline_in(seconds(20)));
  axis.home(axis.deadline_in(seconds(60)));  // a re-home
  // A stream of retargets, each 150 ms after the last, polled in between.
  for (int i = 0; i < 6; ++i) {
    c.write_direct(to(10000 + 3000 * i));
    c.write_direct_start(client::Retry::Never);
    const TimePoint next = clock.now() + milliseconds(150);
    while (clock.now() < next) {
      (void)c.read_flags();
      (void)c.read_state();
    }
  }
  const TimePoint end = clock.now() + seconds(3);
  while (clock.now() < end) (void)c.read_state();
  return pair_exchanges(records);
}

const ChosenBehaviour* chosen(const Calibration& c, std::string_view key) {
  for (const auto& b : c.chosen)
    if (b.key == key) return &b;
  return nullptr;
}

TEST(CalibrateSequences, LearnsHomingAndRetargetFromAFieldLikeTwin) {
  sim::ActuatorConfig a = sim::ideal_config();
  a.initial_position_mm = 300;
  a.origin_speed_mm_s = 45;
  a.seton_on_rehome = sim::ActuatorConfig::SetonOnRehome::Clear;
  a.retarget = sim::ActuatorConfig::Retarget::StopThenStart;
  const auto c = calibrate(session_on(a), modbus::LineTiming{});
  const auto* speed = c.find("actuator.origin_speed_mm_s");
  ASSERT_NE(speed, nullptr) << c.summary();
  EXPECT_NEAR(speed->value, 45.0, 1.0) << c.summary();
  ASSERT_NE(chosen(c, "actuator.homing_direction"), nullptr) << c.summary();
  EXPECT_EQ(chosen(c, "actuator.homing_direction")->value, "min_end");
  ASSERT_NE(chosen(c, "actuator.seton_on_rehome"), nullptr) << c.summary();
  EXPECT_EQ(chosen(c, "actuator.seton_on_rehome")->value, "clear");
  ASSERT_NE(chosen(c, "actuator.retarget"), nullptr) << c.summary();
  EXPECT_EQ(chosen(c, "actuator.retarget")->value, "stop_then_start") << c.summary();
  // The profile `lec sim --calibrate` prints carries them, and reads back.
  const FieldProfile p = parse_field_profile(c.profile_yaml("fitted", "test"), "fitted.yaml");
  EXPECT_EQ(p.actuator.retarget, sim::ActuatorConfig::Retarget::StopThenStart);
  EXPECT_EQ(p.actuator.seton_on_rehome, sim::ActuatorConfig::SetonOnRehome::Clear);
  EXPECT_NEAR(p.actuator.origin_speed_mm_s, 45.0, 1.0);
}

TEST(CalibrateSequences, OnTheIdealTwinNamesTheIdeal) {
  sim::ActuatorConfig a = sim::ideal_config();
  a.initial_position_mm = 300;
  const auto c = calibrate(session_on(a), modbus::LineTiming{});
  ASSERT_NE(chosen(c, "actuator.seton_on_rehome"), nullptr) << c.summary();
  EXPECT_EQ(chosen(c, "actuator.seton_on_rehome")->value, "keep");
  ASSERT_NE(chosen(c, "actuator.retarget"), nullptr) << c.summary();
  EXPECT_EQ(chosen(c, "actuator.retarget")->value, "replan") << c.summary();
  EXPECT_NEAR(c.find("actuator.origin_speed_mm_s")->value, 20.0, 1.0);
}

}  // namespace
}  // namespace lec6::twin
