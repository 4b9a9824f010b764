#include "lec6/client/actuator.hpp"
#include <algorithm>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "sim_fixture.hpp"

namespace lec6::client {
namespace {

using ::testing::HasSubstr;
using testing::SimFixture;

TEST(Actuator, OperationsNeedSerialModeAndSayHowToGetIt) {
  SimFixture f;
  try {
    f.axis->servo_on(f.axis->deadline_in(std::chrono::seconds(1)));
    FAIL();
  } catch (const InvalidRequest& e) {
    EXPECT_THAT(e.what(), HasSubstr("lec serial on"));
  }
}

TEST(Actuator, HomingNeedsServo) {
  SimFixture f;
  f.axis->set_serial_mode(true);
  EXPECT_THROW(f.axis->home(f.axis->deadline_in(std::chrono::seconds(1))), InvalidRequest);
}

TEST(Actuator, HomeClearsSetupAfterwards) {
  SimFixture f;
  f.prepare();
  EXPECT_FALSE(f.client->read_controls().test(lec::Coil::SETUP));
  EXPECT_TRUE(f.client->read_flags().seton());
  EXPECT_EQ(f.client->read_state().position_001mm, 0);
}

TEST(Actuator, MoveBeyondTheStrokeRaisesTheAlarmWithItsMeaning) {
  SimFixture f;
  f.prepare();
  DirectMove m;
  m.position_001mm = 1'000'000;  // 10 m
  try {
    f.axis->move(m, f.axis->deadline_in(std::chrono::seconds(5)));
    FAIL();
  } catch (const AlarmError& e) {
    EXPECT_THAT(e.codes(), ::testing::ElementsAre(lec::alarm::kDirectBeyondStroke));
    EXPECT_THAT(e.what(), HasSubstr("beyond the stroke"));
    EXPECT_THAT(e.what(), HasSubstr("lec reset"));
    ASSERT_TRUE(e.move_result());
    EXPECT_EQ(e.move_result()->outcome, MoveOutcome::Alarm);
    EXPECT_THAT(e.move_result()->alarm_codes,
                ::testing::ElementsAre(lec::alarm::kDirectBeyondStroke));
  }
  EXPECT_EQ(f.client->read_state().position_001mm, 0);  // nothing moved
  EXPECT_TRUE(f.axis->reset_alarms().empty());
  EXPECT_FALSE(f.client->read_flags().alarm());
}

TEST(Actuator, BlankStepIsRefusedBeforeDrive) {
  SimFixture f;
  f.prepare();
  EXPECT_THROW(f.axis->run_step(9, f.axis->deadline_in(std::chrono::seconds(5))), InvalidRequest);
}

TEST(Actuator, CancelStopsTheAxisBeforeReturning) {
  SimFixture f;
  f.prepare();
  DirectMove m;
  m.position_001mm = 30000;
  m.speed_mm_s = 100;
  int polls = 0;
  WaitOptions w;
  w.cancel = [&] { return ++polls > 5; };
  try {
    f.axis->move(m, f.axis->deadline_in(std::chrono::seconds(10)), w);
    FAIL();
  } catch (const Cancelled& e) {
    ASSERT_TRUE(e.move_result());
    EXPECT_EQ(e.move_result()->stop_cause, StopCause::Interrupted);
  }
  const auto flags = f.client->read_flags();
  EXPECT_FALSE(flags.busy());
  const auto pos = f.client->read_state().position_001mm;
  EXPECT_GT(pos, 0);
  EXPECT_LT(pos, 30000);
}

TEST(Actuator, DeadlineIsEnforced) {
  SimFixture f;
  f.prepare();
  DirectMove m;
  m.position_001mm = 30000;
  m.speed_mm_s = 10;  // 30 s
  EXPECT_THROW(f.axis->move(m, f.axis->deadline_in(std::chrono::seconds(1))), DeadlineError);
}

TEST(Actuator, ProgressReportsMotion) {
  SimFixture f;
  f.prepare();
  DirectMove m;
  m.position_001mm = 20000;
  std::vector<int32_t> positions;
  WaitOptions w;
  w.progress = [&](const Progress& p) { positions.push_back(p.state.position_001mm); };
  auto r = f.axis->move(m, f.axis->deadline_in(std::chrono::seconds(10)), w);
  EXPECT_TRUE(r.in_position);
  EXPECT_EQ(r.outcome, MoveOutcome::Reached);
  EXPECT_EQ(r.describe().substr(0, 42), "reached 200.00 mm (INP, within ±0.50 mm) ");
  ASSERT_TRUE(r.timeline.busy_up && r.timeline.busy_down && r.timeline.inp);
  EXPECT_LT(*r.timeline.busy_up, *r.timeline.busy_down);
  EXPECT_EQ(*r.timeline.inp, *r.timeline.busy_down);
  EXPECT_EQ(r.elapsed, *r.timeline.busy_down);
  ASSERT_GT(positions.size(), 5u);
  EXPECT_TRUE(std::is_sorted(positions.begin(), positions.end()));
  EXPECT_EQ(positions.back(), 20000);
}

TEST(Actuator, JogMovesWhileHeldAndStops) {
  SimFixture f;
  f.prepare();
  auto r = f.axis->jog(true, f.axis->deadline_in(std::chrono::seconds(1)),
                       f.axis->deadline_in(std::chrono::seconds(5)));
  EXPECT_FALSE(r.flags.busy());
  EXPECT_GT(r.state.position_001mm, 3000);  // ~50 mm/s for 1 s
  EXPECT_LT(r.state.position_001mm, 6000);
  EXPECT_FALSE(f.client->read_controls().test(lec::Coil::JOG_PLUS));
}

TEST(Actuator, MergeFillsDefaultsUnlessKeep) {
  DirectMove m;
  m.position_001mm = 500;
  const auto d = merge_direct(lec::StepData{}, m);
  EXPECT_TRUE(lec::validate(d).empty());
  EXPECT_EQ(d.position_001mm, 500);
  EXPECT_EQ(d.speed_mm_s, default_direct_data().speed_mm_s);
  auto held = default_direct_data();
  held.speed_mm_s = 321;
  held.in_position_001mm = 2000;
  // A move never inherits what an earlier one left in the controller…
  EXPECT_EQ(merge_direct(held, m).speed_mm_s, default_direct_data().speed_mm_s);
  EXPECT_EQ(merge_direct(held, m).in_position_001mm, 50);
  EXPECT_TRUE(kept_direct_values(held, m).empty());
  // …unless asked to keep it, and then the result names what was kept.
  m.keep = true;
  m.speed_mm_s = 200;
  EXPECT_EQ(merge_direct(held, m).speed_mm_s, 200);
  EXPECT_EQ(merge_direct(held, m).in_position_001mm, 2000);
  const auto kept = kept_direct_values(held, m);
  EXPECT_NE(std::find(kept.begin(), kept.end(), "in position 20.00 mm"), kept.end());
  EXPECT_EQ(std::find(kept.begin(), kept.end(), "speed 321 mm/s"), kept.end());
  // Blank (power-on) data cannot be kept: the defaults fill in, nothing is named.
  EXPECT_EQ(merge_direct(lec::StepData{}, m).in_position_001mm, 50);
  EXPECT_TRUE(kept_direct_values(lec::StepData{}, m).empty());
}

TEST(Actuator, PlainMoveAfterPushReportsTheDefaultBand) {
  SimFixture f;
  f.prepare();
  DirectMove push;
  push.position_001mm = 30000;
  push.pushing_force_pct = 50;
  push.trigger_level_pct = 40;
  push.pushing_speed_mm_s = 10;
  push.in_position_001mm = 2000;
  f.axis->move(push, f.axis->deadline_in(std::chrono::seconds(30)));
  DirectMove plain;
  plain.position_001mm = -2000;
  plain.relative = true;
  const auto r = f.axis->move(plain, f.axis->deadline_in(std::chrono::seconds(30)));
  EXPECT_EQ(r.outcome, MoveOutcome::Reached) << r.describe();
  EXPECT_EQ(r.goal.in_position_001mm, 50) << r.describe();
  EXPECT_NE(r.describe().find("within ±0.50 mm"), std::string::npos) << r.describe();
  // keep: the band of the push stays, and the line says where it came from.
  DirectMove kept = plain;
  kept.keep = true;
  const auto k = f.axis->move(kept, f.axis->deadline_in(std::chrono::seconds(30)));
  EXPECT_EQ(k.goal.in_position_001mm, 50) << k.describe();  // the plain move wrote 0.50 mm
  EXPECT_NE(k.describe().find("kept from the controller: speed 100 mm/s"), std::string::npos)
      << k.describe();
}

TEST(Actuator, SoftLimitsRefuseATargetBeforeAnythingIsWritten) {
  SimFixture f;
  f.prepare();
  f.axis->set_soft_limits(SoftLimits{0, 40000});
  const auto before = f.client->read_direct();
  DirectMove far;
  far.position_001mm = 999900;
  try {
    f.axis->move(far, f.axis->deadline_in(std::chrono::seconds(5)));
    FAIL() << "a target beyond the soft limits was sent";
  } catch (const InvalidRequest& e) {
    EXPECT_NE(std::string(e.what()).find("9999.00 mm is beyond the soft limits 0.00 to 400.00 mm"),
              std::string::npos)
        << e.what();
  }
  EXPECT_EQ(f.client->read_direct().to_registers(), before.to_registers());
  EXPECT_FALSE(f.client->read_flags().alarm());
  // INC: the previous target plus the distance is checked.
  DirectMove inc;
  inc.position_001mm = 50000;
  inc.relative = true;
  EXPECT_THROW(f.axis->move(inc, f.axis->deadline_in(std::chrono::seconds(5))), InvalidRequest);
  DirectMove near;
  near.position_001mm = 20000;
  EXPECT_EQ(f.axis->move(near, f.axis->deadline_in(std::chrono::seconds(30))).outcome,
            MoveOutcome::Reached);
}

bool is_write_frame(const modbus::Bytes& b) {
  return b.size() > 1 && (b[1] == 0x05 || b[1] == 0x0F || b[1] == 0x10);
}

TEST(Actuator, MoveChecksSerialModeBeforeWritingAnything) {
  SimFixture f;  // power-on: parallel input mode
  DirectMove m;
  m.position_001mm = 10000;
  try {
    f.axis->move(m, f.axis->deadline_in(std::chrono::seconds(5)));
    FAIL();
  } catch (const InvalidRequest& e) {
    EXPECT_THAT(e.what(), HasSubstr("lec serial on"));
  }
  ASSERT_FALSE(f.sent.empty());
  for (const auto& frame : f.sent) EXPECT_FALSE(is_write_frame(frame)) << modbus::to_hex(frame);
}

TEST(Actuator, AMoveStoppedByAnotherMasterIsStoppedNeverReached) {
  SimFixture f;
  f.prepare();
  DirectMove m;
  m.position_001mm = 15000;
  WaitOptions w;
  bool stopped = false;
  w.progress = [&](const Progress& p) {
    if (!stopped && p.state.position_001mm > 5000) {
      stopped = true;  // "another master" (same line, between two polls) sends a stop
      f.client->write_coil(lec::Coil::RESET, true);
      f.client->write_coil(lec::Coil::RESET, false);
    }
  };
  const auto r = f.axis->move(m, f.axis->deadline_in(std::chrono::seconds(10)), w);
  EXPECT_EQ(r.outcome, MoveOutcome::Stopped);
  EXPECT_EQ(r.stop_cause, StopCause::Unknown);
  EXPECT_FALSE(r.succeeded());
  EXPECT_LT(r.state.position_001mm, 15000);
  EXPECT_THAT(r.describe(), HasSubstr("before the target 150.00 mm"));
}

TEST(Actuator, AStartTheControllerNeverShowsIsNotStartedAndIsStopped) {
  sim::ActuatorConfig slow;
  slow.busy_delay = std::chrono::milliseconds(600);  // far beyond the 200 ms start window
  slow.target_update_late = true;
  SimFixture f({}, {1}, slow);
  f.axis->set_serial_mode(true);
  f.axis->servo_on(f.axis->deadline_in(std::chrono::seconds(2)));
  WaitOptions patient;
  patient.completion.start_window = std::chrono::seconds(1);
  f.axis->home(f.axis->deadline_in(std::chrono::seconds(30)), patient);
  DirectMove m;
  m.position_001mm = 15000;
  try {
    f.axis->move(m, f.axis->deadline_in(std::chrono::seconds(10)));
    FAIL();
  } catch (const MoveNotStarted& e) {
    EXPECT_THAT(e.what(), HasSubstr("did not start the move"));
    ASSERT_TRUE(e.move_result());
    EXPECT_EQ(e.move_result()->outcome, MoveOutcome::NotStarted);
  }
  // The stop sent with it cancelled the late start: nothing moves afterwards.
  f.client->idle_until(f.clock.now() + std::chrono::seconds(2));
  EXPECT_EQ(f.client->read_state().position_001mm, 0);
  EXPECT_FALSE(f.client->read_flags().busy());
  EXPECT_TRUE(f.bus.find(1)->operations().back().cancelled);
}

TEST(Actuator, PollIntervalSpacesThePolls) {
  SimFixture f;
  f.prepare();
  DirectMove m;
  m.position_001mm = 20000;
  m.speed_mm_s = 100;  // ~2 s
  int polls = 0;
  WaitOptions w;
  w.poll_interval = std::chrono::milliseconds(100);
  w.progress = [&](const Progress&) { ++polls; };
  const auto r = f.axis->move(m, f.axis->deadline_in(std::chrono::seconds(10)), w);
  EXPECT_EQ(r.outcome, MoveOutcome::Reached);
  const double expected = to_seconds(r.elapsed) / 0.1;
  EXPECT_NEAR(polls, expected, 2.0);
}

TEST(Actuator, CtrlCOnTheLineStopsTheAxisAndTheStopStillGoesOut) {
  SimFixture f;
  f.prepare();
  bool interrupted = false;
  client::ClientOptions o;
  o.interrupted = [&] { return interrupted; };
  f.reconnect(o);
  DirectMove m;
  m.position_001mm = 30000;
  m.speed_mm_s = 100;
  WaitOptions w;
  w.progress = [&](const Progress& p) { interrupted = p.state.position_001mm > 5000; };
  try {
    f.axis->move(m, f.axis->deadline_in(std::chrono::seconds(10)), w);
    FAIL();
  } catch (const Cancelled& e) {
    ASSERT_TRUE(e.move_result());
    EXPECT_EQ(e.move_result()->stop_cause, StopCause::Interrupted);
  }
  interrupted = false;
  f.client->idle_until(f.clock.now() + std::chrono::seconds(1));
  EXPECT_FALSE(f.client->read_flags().busy()) << "the RESET pulse went out while interrupted";
  EXPECT_LT(f.client->read_state().position_001mm, 30000);
  EXPECT_FALSE(f.client->read_controls().test(lec::Coil::RESET));
}

TEST(Actuator, RetargetWritesOnlyThePositionAndTheStart) {
  SimFixture f;
  f.prepare();
  DirectMove m;
  m.position_001mm = 10000;
  f.axis->start(m);
  f.sent.clear();
  f.axis->retarget(12000);
  ASSERT_EQ(f.sent.size(), 2u);
  EXPECT_EQ(modbus::to_hex(f.sent[0]).substr(0, 17), "01 10 91 05 00 01");  // D9105 (low word)
  EXPECT_EQ(modbus::to_hex(f.sent[1]).substr(0, 17), "01 10 91 00 00 01");  // D9100
  f.sent.clear();
  f.axis->retarget(13000, 321);
  ASSERT_EQ(f.sent.size(), 2u);
  EXPECT_EQ(modbus::to_hex(f.sent[0]).substr(0, 17), "01 10 91 03 00 03");  // speed + position
  const auto r =
      f.axis->wait(f.axis->retarget(14000), f.axis->deadline_in(std::chrono::seconds(5)));
  EXPECT_EQ(r.outcome, MoveOutcome::Reached);
  EXPECT_EQ(r.state.position_001mm, 14000);
}

}  // namespace
}  // namespace lec6::client

namespace lec6::client {
namespace {

// A stop whose RESET ← 1 was heard but whose replies were all lost still
// sends RESET ← 0: otherwise RESET stays at 1 in the controller and the next
// stop (the next RESET ← 1) is no rising edge, so no stop at all.
TEST(Actuator, AStopReleasesResetEvenWhenTheRisingHalfGotNoAnswer) {
  testing::SimFixture f;
  f.axis->set_serial_mode(true);
  sim::FaultConfig faults;
  faults.drop = 1.0;  // the controller hears every query; its replies are lost
  f.bus.set_faults(faults);
  f.sent.clear();
  EXPECT_THROW(f.axis->stop(), TransportError);
  const modbus::Bytes reset_off =
      *modbus::encode_request({1, modbus::WriteCoilRequest{0x1B, modbus::kCoilOff}});
  EXPECT_FALSE(f.sent.empty());
  EXPECT_EQ(f.sent.back(), reset_off) << "the falling half was never sent";
  EXPECT_FALSE(f.bus.find(1)->control().test(lec::Coil::RESET)) << "RESET left at 1";
}

// A noisy line loses every reply for a second in the middle of a move: with a
// grace (what lec serve sets), the wait sees the move through to its end.
struct LostPolls {
  testing::SimFixture f;
  DirectMove m;
  std::optional<TimePoint> lost_from;
  Duration lost_for{};

  LostPolls() {
    f.prepare();
    m.position_001mm = 20000;
    m.speed_mm_s = 100;  // 200 mm: ~2 s
    f.on_trace = [this](const TraceEvent&) {
      if (lost_from && f.clock.now() >= *lost_from + lost_for) f.bus.set_faults({});
    };
  }
  WaitOptions losing(Duration after, Duration for_, Duration grace) {
    WaitOptions w;
    w.unanswered_grace = grace;
    w.progress = [this, after, for_](const Progress& p) {
      if (!lost_from && p.elapsed >= after) {
        sim::FaultConfig faults;
        faults.drop = 1.0;
        f.bus.set_faults(faults);
        lost_from = f.clock.now();
        lost_for = for_;
      }
    };
    return w;
  }
};

TEST(Actuator, AMoveOutlivesASecondOfLostPollsWithinItsGrace) {
  LostPolls t;
  const auto w =
      t.losing(std::chrono::milliseconds(500), std::chrono::seconds(1), std::chrono::seconds(3));
  const auto r = t.f.axis->move(t.m, t.f.axis->deadline_in(std::chrono::seconds(20)), w);
  ASSERT_TRUE(t.lost_from);
  EXPECT_EQ(r.outcome, MoveOutcome::Reached);
  EXPECT_EQ(t.f.client->read_state().position_001mm, 20000);
}

TEST(Actuator, WithoutAGraceTheFirstUnansweredPollEndsTheWait) {
  LostPolls t;
  const auto w = t.losing(std::chrono::milliseconds(500), std::chrono::seconds(1), Duration{});
  EXPECT_THROW(t.f.axis->move(t.m, t.f.axis->deadline_in(std::chrono::seconds(20)), w),
               TransportError);
}

TEST(Actuator, PollsUnansweredLongerThanTheGraceEndTheWaitSayingHowLong) {
  LostPolls t;
  const auto w =
      t.losing(std::chrono::milliseconds(500), std::chrono::hours(1), std::chrono::seconds(3));
  try {
    t.f.axis->move(t.m, t.f.axis->deadline_in(std::chrono::seconds(20)), w);
    FAIL() << "the move was reported without an answer";
  } catch (const TransportError& e) {
    EXPECT_EQ(e.kind(), TransportErrorKind::Timeout);
    EXPECT_THAT(e.what(), HasSubstr("unanswered for 3."));
    EXPECT_THAT(e.what(), HasSubstr("may still be moving"));
    ASSERT_TRUE(t.lost_from);
    const double waited = to_seconds(t.f.clock.now() - *t.lost_from);
    EXPECT_GE(waited, 3.0);
    EXPECT_LT(waited, 3.5);
  }
}

// WaitOptions::poll_jitter (lec serve: 0 to one transaction, issue 32):
// every poll comes that much later, is dated when it was on the wire (not
// before the wait), the move still ends reached, and a cancel is still seen
// at the next poll.
TEST(Actuator, APollJitterDelaysEachPollAndTheMoveStillEnds) {
  std::vector<Duration> shortest;  // between two flags reads of the move: without, with
  for (const Duration jitter : {Duration{}, Duration(std::chrono::milliseconds(15))}) {
    SimFixture f;
    f.prepare();
    std::vector<TimePoint> flags_reads;  // FC02 queries sent during the move
    bool moving = false;
    f.on_trace = [&](const TraceEvent& e) {
      if (moving && e.outgoing && e.bytes.size() > 1 && e.bytes[1] == 0x02)
        flags_reads.push_back(e.at);
    };
    WaitOptions w;
    if (jitter > Duration{}) w.poll_jitter = [jitter] { return jitter; };
    DirectMove m;
    m.position_001mm = 10000;
    moving = true;
    const MoveResult r = f.axis->move(m, f.axis->deadline_in(std::chrono::seconds(30)), w);
    moving = false;
    EXPECT_EQ(r.outcome, MoveOutcome::Reached) << r.describe();
    ASSERT_GE(flags_reads.size(), 3u);
    Duration least = Duration::max();
    for (std::size_t i = 1; i < flags_reads.size(); ++i)
      least = std::min(least, flags_reads[i] - flags_reads[i - 1]);
    shortest.push_back(least);
  }
  // Back to back, a poll round (flags, then state); with the jitter, 15 ms
  // more each, less the silent interval before a query that the wait covers.
  EXPECT_GE(shortest[1], shortest[0] + std::chrono::milliseconds(14));
  EXPECT_LT(shortest[1], shortest[0] + std::chrono::milliseconds(17));
}

TEST(Actuator, ACancelIsSeenAtTheNextPollWithAJitter) {
  SimFixture f;
  f.prepare();
  WaitOptions w;
  w.poll_jitter = [] { return Duration(std::chrono::milliseconds(15)); };
  const TimePoint cancel_at = f.clock.now() + std::chrono::milliseconds(300);
  w.cancel = [&] { return f.clock.now() >= cancel_at; };
  DirectMove m;
  m.position_001mm = 30000;
  m.speed_mm_s = 50;
  try {
    f.axis->move(m, f.axis->deadline_in(std::chrono::seconds(30)), w);
    ADD_FAILURE() << "the move ran to its end";
  } catch (const Cancelled&) {
  }
  // Within one poll round (the jitter, flags and state reads) of the cancel,
  // plus the stop that follows it.
  EXPECT_LT(f.clock.now() - cancel_at, std::chrono::milliseconds(600));
}

}  // namespace
}  // namespace lec6::client
