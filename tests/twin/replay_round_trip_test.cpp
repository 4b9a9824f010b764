// Issue 24's proof, on a virtual clock: record a session with a twin far from
// the defaults, calibrate from the recording, and replay it against the
// calibrated twin (it matches) and against the default twin (it reports each
// difference). The recording goes through transport::RecordingLink, the
// record hook of `lec --record`.

#include <gtest/gtest.h>

#include <iostream>
#include <memory>

#include "lec6/client/actuator.hpp"
#include "lec6/client/client.hpp"
#include "lec6/client/rtu_master.hpp"
#include "lec6/sim/bus.hpp"
#include "lec6/transport/recording_link.hpp"
#include "lec6/twin/calibrate.hpp"
#include "lec6/twin/field_profile.hpp"
#include "lec6/twin/replay.hpp"
#include "lec6/twin/replay_run.hpp"
#include "lec6/twin/sim_link.hpp"

namespace lec6::twin {
namespace {

using std::chrono::milliseconds;

// The twin the session is recorded on: far from the defaults.
FieldProfile unusual() {
  FieldProfile p;
  p.actuator.busy_delay = milliseconds(25);
  p.actuator.busy_min = milliseconds(60);
  p.actuator.max_accel_mm_s2 = 2500;
  p.line.line.delay_td = milliseconds(7);
  p.faults.delay = 0.1;  // a late response now and then
  p.faults.extra_delay = milliseconds(30);
  return p;
}

std::vector<LineRecord> record_session(const FieldProfile& p) {
  VirtualClock clock{TimePoint{} + std::chrono::seconds(1)};
  sim::Bus bus(p.line, p.faults);
  bus.add(1, p.actuator, clock.now());
  SimLink link(bus, clock);
  const TimePoint origin = clock.now();
  std::vector<LineRecord> records;
  auto us = [&](TimePoint t) {
    return std::chrono::duration_cast<std::chrono::microseconds>(t - origin).count();
  };
  {
    transport::RecordingLink rec(link, [&](transport::LineChunk&& c) {
      LineRecord r;
      r.kind = c.sent ? LineRecord::Kind::Query : LineRecord::Kind::Reply;
      r.t_us = us(c.start);
      r.end_us = us(c.end);
      r.bytes = std::move(c.bytes);
      r.line = records.size() + 2;
      records.push_back(std::move(r));
    });
    client::ClientOptions o;
    o.delay_td = milliseconds(7);
    client::Client c(rec, o);
    client::Actuator axis(c);
    axis.set_serial_mode(true);
    axis.servo_on(axis.deadline_in(std::chrono::seconds(2)));
    axis.home(axis.deadline_in(std::chrono::seconds(60)));
    const int32_t targets[] = {5000, 12000, 3000, 20000, 8000, 15000, 1000, 9000, 17000, 4000,
                               11000, 6000};
    for (int i = 0; i < 12; ++i) {
      // Varied idle gaps, so the polls meet the edges at different phases.
      c.idle_until(clock.now() + std::chrono::microseconds(1700 * i + 500));
      client::DirectMove m;
      m.position_001mm = targets[i];
      m.speed_mm_s = static_cast<uint16_t>(200 + 25 * i);
      m.acceleration_mm_s2 = 5000;
      m.deceleration_mm_s2 = 4000;
      axis.move(m, axis.deadline_in(std::chrono::seconds(20)));
      // Again to where it is: only the shortest BUSY pulse.
      c.idle_until(clock.now() + std::chrono::microseconds(2300 * i + 300));
      axis.move(m, axis.deadline_in(std::chrono::seconds(20)));
    }
  }
  return records;
}

std::vector<Exchange> replay_on(const FieldProfile& p, std::span<const Exchange> captured) {
  VirtualClock clock{TimePoint{} + std::chrono::seconds(1)};
  sim::Bus bus(p.line, p.faults);
  bus.add(1, p.actuator, clock.now());
  SimLink link(bus, clock);
  client::RtuOptions o;
  o.delay_td = p.line.line.delay_td;
  client::RtuMaster master(link, o);
  return run_replay(master, captured, ReplayTiming::AsCaptured);
}

class RoundTrip : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    records = new std::vector<LineRecord>(record_session(unusual()));
    captured = new std::vector<Exchange>(pair_exchanges(*records));
  }
  static void TearDownTestSuite() {
    delete records;
    delete captured;
  }
  static std::vector<LineRecord>* records;
  static std::vector<Exchange>* captured;
};
std::vector<LineRecord>* RoundTrip::records = nullptr;
std::vector<Exchange>* RoundTrip::captured = nullptr;

void expect_within(const Calibration& c, std::string_view key, double want, double ratio) {
  const auto* f = c.find(key);
  ASSERT_NE(f, nullptr) << key << " was not fitted:\n" << c.summary();
  EXPECT_NEAR(f->value, want, want * ratio) << key << "\n" << c.summary();
}

TEST_F(RoundTrip, TheRecordingHoldsEveryQueryAndReply) {
  ASSERT_GT(captured->size(), 300u);
  std::size_t replies = 0;
  for (const auto& e : *captured) replies += e.reply ? 1 : 0;
  EXPECT_EQ(replies, captured->size());  // the twin answered everything (late, sometimes)
  for (std::size_t i = 1; i < records->size(); ++i)
    EXPECT_LE((*records)[i - 1].t_us, (*records)[i].t_us);
}

TEST_F(RoundTrip, CalibrationRecoversTheParametersWithinFivePercent) {
  const auto c = calibrate(*captured, modbus::LineTiming{});
  expect_within(c, "line.delay_ms", 7.0, 0.05);
  expect_within(c, "actuator.busy_delay_ms", 25.0, 0.05);
  expect_within(c, "actuator.max_accel_mm_s2", 2500.0, 0.05);
  expect_within(c, "actuator.busy_min_ms", 60.0, 0.05);
  expect_within(c, "faults.extra_delay_ms", 30.0, 0.05);
  expect_within(c, "actuator.origin_speed_mm_s", 20.0, 0.05);
  std::cout << c.summary();  // the figures, for the log
  // What it cannot know from this session, it says.
  EXPECT_NE(c.summary().find("could not determine"), std::string::npos);
  EXPECT_NE(c.summary().find("max speed"), std::string::npos);
}

TEST_F(RoundTrip, ReplayAgainstTheCalibratedTwinMatches) {
  const auto c = calibrate(*captured, modbus::LineTiming{});
  // The profile as `lec sim --calibrate` prints it, read back as `lec sim --profile` reads it.
  const FieldProfile fitted = parse_field_profile(c.profile_yaml("fitted", "test"), "fitted.yaml");
  const auto replayed = replay_on(fitted, *captured);
  const auto report = compare(*captured, replayed);
  EXPECT_EQ(report.differing, 0u) << report.text();
  EXPECT_LE(report.max_position_delta_mm, 0.05) << report.text();
  EXPECT_TRUE(report.response_time_matches) << report.text();
  EXPECT_TRUE(report.matches()) << report.text();
}

TEST_F(RoundTrip, ReplayAgainstTheDefaultTwinReportsEachDifference) {
  const auto replayed = replay_on(FieldProfile{}, *captured);
  const auto report = compare(*captured, replayed);
  EXPECT_FALSE(report.matches());
  EXPECT_GT(report.differing, 0u);
  EXPECT_FALSE(report.response_time_matches);
  const std::string text = report.text(1000);
  EXPECT_NE(text.find("D9000 position: captured"), std::string::npos) << text;
  EXPECT_NE(text.find("X48 BUSY"), std::string::npos) << text;
  EXPECT_NE(text.find("response time: captured p50"), std::string::npos) << text;
  EXPECT_NE(report.json().find("\"differences\""), std::string::npos);
}

}  // namespace
}  // namespace lec6::twin
