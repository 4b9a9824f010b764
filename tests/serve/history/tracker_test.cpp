// From operations events and telemetry reads to motion records (sans-I/O,
// on a virtual clock's time points).

#include "serve/history/tracker.hpp"

#include <gtest/gtest.h>

#include "serve/history/history_http.hpp"
#include "serve/history/odometer.hpp"

namespace lec6::serve::history {
namespace {

using namespace std::chrono_literals;

lec::StateData state(double mm, uint16_t speed, uint16_t thrust, double target_mm) {
  lec::StateData s;
  s.position_001mm = static_cast<int32_t>(mm * 100);
  s.speed_mm_s = speed;
  s.thrust_pct = thrust;
  s.target_001mm = static_cast<int32_t>(target_mm * 100);
  return s;
}

lec::StatusFlags flags(bool busy, bool inp) {
  lec::StatusFlags f;
  f.set(lec::StatusFlags::Busy, busy);
  f.set(lec::StatusFlags::Inp, inp);
  return f;
}

TEST(Tracker, AnOperationsMoveTakesItsSettingsOutcomeAndTimelineAndTheSamplesBetween) {
  MotionTracker t("x");
  TimePoint now{};
  EXPECT_FALSE(t.telemetry(state(10, 0, 5, 10), flags(false, true), now, 1000));
  nlohmann::json started{{"event", "started"}, {"op", "move"},      {"source", "http 127.0.0.1"},
                         {"target_mm", 150.0}, {"speed_mm_s", 100}, {"moving_force_pct", 100}};
  EXPECT_FALSE(t.op_event(started, now, 1000));
  double pos[] = {20, 60, 110, 150.3, 150.0};
  uint16_t thrust[] = {60, 40, 35, 50, 10};
  for (int i = 0; i < 5; ++i) {
    now += 300ms;
    EXPECT_FALSE(t.telemetry(state(pos[i], i < 3 ? 100 : 0, thrust[i], 150), flags(i < 3, i >= 3),
                             now, 1000 + 300 * (i + 1)));
  }
  nlohmann::json finished{
      {"event", "finished"},
      {"op", "move"},
      {"outcome", "reached"},
      {"ok", true},
      {"position_mm", 150.0},
      {"target_mm", 150.0},
      {"speed_mm_s", 0},
      {"thrust_pct", 10},
      {"elapsed_s", 1.5},
      {"timeline", {{"busy_up_s", 0.02}, {"busy_down_s", 1.2}, {"inp_s", 1.26}}}};
  const auto r = t.op_event(finished, now, 2500);
  ASSERT_TRUE(r);
  EXPECT_EQ(r->axis, "x");
  EXPECT_EQ(r->kind, "move");
  EXPECT_EQ(r->source, "http 127.0.0.1");
  EXPECT_EQ(r->start_ms, 1000);
  EXPECT_EQ(r->start_mm, 10);
  EXPECT_EQ(r->target_mm, 150);
  EXPECT_EQ(r->speed_mm_s, 100);
  EXPECT_EQ(r->force_pct, 100);
  EXPECT_EQ(r->outcome, "reached");
  EXPECT_DOUBLE_EQ(r->duration_s, 1.2);
  EXPECT_NEAR(*r->settle_s, 0.06, 1e-9);
  EXPECT_EQ(r->peak_thrust_pct, 60);
  EXPECT_EQ(r->peak_speed_mm_s, 100);
  EXPECT_NEAR(*r->overshoot_mm, 0.3, 1e-9);
  EXPECT_NEAR(*r->final_error_mm, 0, 1e-9);
  EXPECT_NEAR(r->distance_mm, 140.6, 1e-9);
}

TEST(Tracker, AMoveAnotherMasterStartedIsRecordedFromTheTelemetry) {
  MotionTracker t("x");
  TimePoint now{};
  EXPECT_FALSE(t.telemetry(state(100, 0, 3, 100), flags(false, true), now, 0));
  now += 100ms;
  EXPECT_FALSE(t.telemetry(state(90, 50, 30, 20), flags(true, false), now, 100));
  now += 1s;
  EXPECT_FALSE(t.telemetry(state(30, 50, 30, 20), flags(true, false), now, 1100));
  now += 300ms;
  EXPECT_FALSE(t.telemetry(state(20, 0, 8, 20), flags(false, false), now, 1400));
  now += 100ms;
  const auto r = t.telemetry(state(20, 0, 8, 20), flags(false, true), now, 1500);
  ASSERT_TRUE(r);
  EXPECT_EQ(r->source, "telemetry");
  EXPECT_EQ(r->start_ms, 100);
  EXPECT_EQ(r->start_mm, 100);
  EXPECT_EQ(r->target_mm, 20);
  EXPECT_EQ(r->outcome, "reached");
  // BUSY rose between the reads at 0 and 0.1 s and fell between 1.1 and
  // 1.4 s: 1.2 ± 0.2 s (issue 32: the middle of each bracket).
  EXPECT_NEAR(r->duration_s, 1.2, 1e-9);
  EXPECT_NEAR(*r->duration_pm_s, 0.2, 1e-9);
  // INP rose between 1.4 and 1.5 s: from the middle of BUSY's fall (1.25 s)
  // to the middle of INP's rise (1.45 s), 0.2 s (rule 5).
  EXPECT_NEAR(*r->settle_s, 0.2, 1e-9);
  EXPECT_EQ(r->peak_thrust_pct, 30);
  EXPECT_NEAR(r->distance_mm, 80, 1e-9);
}

// Issue 32, rule 1: a telemetry read shows what the controller sampled
// between the read's start and its reply's end (the line's own times); an
// edge it saw happened after the previous read began, not after it ended.
TEST(Tracker, TelemetryBracketsOpenWhenThePreviousReadBegan) {
  MotionTracker t("x");
  const TimePoint t0{};
  auto read = [&](double sent_ms, double mm, bool busy, bool inp) {
    const auto sent = t0 + std::chrono::milliseconds(int64_t(sent_ms));
    return t.telemetry(state(mm, busy ? 50 : 0, 10, 20), flags(busy, inp), sent + 15ms, 0, sent);
  };
  EXPECT_FALSE(read(0, 100, false, true));
  EXPECT_FALSE(read(100, 95, true, false));
  EXPECT_FALSE(read(1100, 30, true, false));
  const auto r = read(1400, 20, false, true);
  ASSERT_TRUE(r);
  // BUSY rose within 0-115 ms and fell within 1100-1415 ms: 1.2 ± 0.215 s
  // (dated by the reads' ends alone: ± 0.2 s, too narrow by a read each).
  EXPECT_NEAR(r->duration_s, 1.2, 1e-9);
  EXPECT_NEAR(*r->duration_pm_s, 0.215, 1e-9);
}

TEST(Tracker, AfterAnOperationEndsTheTailOfItsBusyIsNotAnotherMotion) {
  MotionTracker t("x");
  TimePoint now{};
  t.telemetry(state(10, 0, 5, 10), flags(false, true), now, 0);
  t.op_event({{"event", "started"}, {"op", "move"}, {"source", "mqtt"}}, now, 0);
  now += 200ms;
  t.telemetry(state(30, 100, 40, 150), flags(true, false), now, 200);
  const auto r = t.op_event(
      {{"event", "finished"}, {"op", "move"}, {"outcome", "stopped"}, {"position_mm", 31.0}}, now,
      200);
  ASSERT_TRUE(r);
  EXPECT_EQ(r->outcome, "stopped");
  now += 100ms;
  EXPECT_FALSE(t.telemetry(state(33, 20, 10, 150), flags(true, false), now, 300));
  now += 100ms;
  EXPECT_FALSE(t.telemetry(state(33, 0, 5, 150), flags(false, false), now, 400));
  now += 2s;
  EXPECT_FALSE(t.telemetry(state(33, 0, 5, 150), flags(false, false), now, 2400));
}

TEST(Tracker, ARefusedMoveIsAnEventNotAMotion) {
  // The three refusals of issue 32 as operations report them: servo off and
  // a soft limit (409, InvalidRequest), an alarm already active (422 with
  // alarms, but no timeline: nothing was started).
  const nlohmann::json refusals[] = {{{"event", "finished"},
                                      {"op", "move"},
                                      {"ok", false},
                                      {"status", 409},
                                      {"error", "the move needs the servo on (SVRE = 0)"}},
                                     {{"event", "finished"},
                                      {"op", "move"},
                                      {"ok", false},
                                      {"status", 409},
                                      {"error", "target 900 mm is beyond the soft limits"}},
                                     {{"event", "finished"},
                                      {"op", "home"},
                                      {"ok", false},
                                      {"status", 422},
                                      {"outcome", "alarm"},
                                      {"alarms", {{{"code", 98}}}}}};
  for (const auto& refused : refusals) {
    MotionTracker t("x");
    TimePoint now{};
    t.telemetry(state(10, 0, 5, 10), flags(false, true), now, 0);
    t.op_event({{"event", "started"}, {"op", refused["op"]}, {"source", "mqtt"}}, now, 0);
    now += 30ms;
    const auto r = t.op_event(refused, now, 30);
    ASSERT_TRUE(r);
    EXPECT_EQ(r->outcome, "refused");
    EXPECT_TRUE(r->alarms.empty());
    Odometer o;
    o.add(*r);
    EXPECT_EQ(o.moves, 0);
    EXPECT_EQ(o.alarms, 0);
  }
  // A move that ran and ended on an alarm counts, with its alarm.
  MotionTracker t("x");
  TimePoint now{};
  t.op_event({{"event", "started"}, {"op", "move"}, {"source", "mqtt"}}, now, 0);
  now += 500ms;
  const auto r = t.op_event({{"event", "finished"},
                             {"op", "move"},
                             {"status", 422},
                             {"outcome", "alarm"},
                             {"alarms", {{{"code", 98}}}},
                             {"timeline", {{"busy_up_s", 0.02}, {"busy_down_s", nullptr}}}},
                            now, 500);
  ASSERT_TRUE(r);
  EXPECT_EQ(r->outcome, "alarm");
  Odometer o;
  o.add(*r);
  EXPECT_EQ(o.moves, 1);
  EXPECT_EQ(o.alarms, 1);
}

TEST(Tracker, AMotionLeftAtRestIsClosedNotCountedForTheWholeHold) {
  MotionTracker t("x");
  TimePoint now{};
  t.telemetry(state(100, 0, 3, 100), flags(false, true), now, 0);
  now += 100ms;
  t.telemetry(state(90, 50, 30, 20), flags(true, false), now, 100);
  now += 500ms;
  t.telemetry(state(60, 50, 30, 20), flags(true, false), now, 600);
  // Held at 60 mm, BUSY on, for a weekend (a read a second).
  std::optional<MotionRecord> r;
  for (int i = 0; i < 48 * 3600 && !r; ++i) {
    now += 1s;
    r = t.telemetry(state(60, 0, 10, 20), flags(true, false), now, 600 + 1000 * (i + 1));
  }
  ASSERT_TRUE(r);
  EXPECT_EQ(r->outcome, "stopped");
  EXPECT_LT(r->duration_s, 2.0);  // up to the carriage's stop, not 48 h
  // The rest of that BUSY, and its fall, make no other motion.
  now += 1h;
  EXPECT_FALSE(t.telemetry(state(60, 0, 10, 20), flags(true, false), now, 0));
  now += 100ms;
  EXPECT_FALSE(t.telemetry(state(60, 0, 10, 20), flags(false, true), now, 0));
}

// Issue 32: an operation of lec serve held for hours (HOLD on: BUSY stays 1,
// the carriage at rest) is one short motion that ends where the carriage
// stopped, closed 60 s later; memory stays bounded meanwhile, and the
// operation's own end (its deadline, hours later) adds nothing.
TEST(Tracker, AnOperationHeldForHoursIsClosedAtRestWithBoundedMemory) {
  MotionTracker t("x");
  TimePoint now{};
  t.telemetry(state(10, 0, 3, 10), flags(false, true), now, 0);
  t.op_event(
      {{"event", "started"}, {"op", "move"}, {"source", "http 127.0.0.1"}, {"target_mm", 150.0}},
      now, 0);
  now += 20ms;
  EXPECT_FALSE(t.telemetry(state(10, 0, 3, 150), flags(false, false), now, 0));
  for (int i = 1; i <= 5; ++i) {  // 0.5 s of motion, then HOLD stops it at 60 mm
    now += 100ms;
    EXPECT_FALSE(t.telemetry(state(10 + 10 * i, 100, 30, 150), flags(true, false), now, 0));
  }
  std::optional<MotionRecord> r;
  int reads = 0;
  for (; reads < 10 * 3600 * 10 && !r; ++reads) {  // up to 10 h at 10 Hz
    now += 100ms;
    r = t.telemetry(state(60, 0, 8, 150), flags(true, false), now, 0);
    EXPECT_LE(t.samples_kept(), kMaxSamples);
  }
  ASSERT_TRUE(r) << "an operation held at rest for 10 h was never closed";
  EXPECT_LE(reads, 61 * 10) << "closed 60 s after the carriage stopped";
  EXPECT_EQ(r->outcome, "stopped");
  EXPECT_EQ(r->source, "http 127.0.0.1");
  EXPECT_NEAR(r->duration_s, 0.5, 0.15);  // BUSY seen to the carriage's stop, not hours
  EXPECT_NEAR(*r->start_mm, 10, 1e-9);
  EXPECT_NEAR(r->distance_mm, 50, 1e-9);
  // The rest of the hold, the operation's deadline and BUSY's fall add nothing.
  for (int i = 0; i < 1000; ++i) {
    now += 1s;
    EXPECT_FALSE(t.telemetry(state(60, 0, 8, 150), flags(true, false), now, 0));
  }
  EXPECT_FALSE(t.op_event({{"event", "finished"},
                           {"op", "move"},
                           {"status", 504},
                           {"outcome", "deadline"},
                           {"timeline", {{"busy_up_s", 0.02}}}},
                          now, 0));
  now += 100ms;
  EXPECT_FALSE(t.telemetry(state(60, 0, 0, 150), flags(false, false), now, 0));
}

TEST(Tracker, ALongMotionKeepsBoundedSamples) {
  MotionTracker t("x");
  TimePoint now{};
  t.telemetry(state(0, 0, 3, 0), flags(false, true), now, 0);
  t.op_event({{"event", "started"}, {"op", "jog"}, {"source", "mqtt"}}, now, 0);
  // A slow jog of 10 h at 10 Hz: 360 000 samples, one thrust peak in them.
  for (int i = 1; i <= 360'000; ++i) {
    now += 100ms;
    t.telemetry(state(i * 0.001, 1, i == 200'001 ? 90 : 20, 400), flags(true, false), now, 0);
  }
  EXPECT_LE(t.samples_kept(), kMaxSamples);
  const auto r = t.op_event({{"event", "finished"},
                             {"op", "jog"},
                             {"status", 200},
                             {"outcome", "stopped"},
                             {"position_mm", 360.0}},
                            now, 0);
  ASSERT_TRUE(r);
  EXPECT_EQ(r->peak_thrust_pct, 90);  // the peak survives the merging
  EXPECT_NEAR(r->distance_mm, 360, 0.01);
}

TEST(HistoryQueryParse, BadFiltersNameTheParameter) {
  auto err = [](std::map<std::string, std::string> q) {
    auto r = parse_query("x", q);
    return std::holds_alternative<QueryError>(r) ? std::get<QueryError>(r).parameter
                                                 : std::string("(accepted)");
  };
  EXPECT_EQ(err({{"since", "yesterday"}}), "since");
  EXPECT_EQ(err({{"until", "2026-13-01"}}), "until");
  EXPECT_EQ(err({{"kind", "fly"}}), "kind");
  EXPECT_EQ(err({{"outcome", "meh"}}), "outcome");
  EXPECT_EQ(err({{"step", "64"}}), "step");
  EXPECT_EQ(err({{"limit", "0"}}), "limit");
  EXPECT_EQ(err({{"limit", "10001"}}), "limit");
  EXPECT_EQ(err({{"before", "-3"}}), "before");
  EXPECT_EQ(err({{"format", "xml"}}), "format");
  EXPECT_EQ(err({{"colour", "red"}}), "colour");
  EXPECT_EQ(err({{"since", "2026-11-24"}, {"until", "2026-11-23"}}), "until");
  EXPECT_EQ(err({{"since", "2026-11-24T10:00:00Z"},
                 {"kind", "run-step"},
                 {"step", "3"},
                 {"limit", "50"},
                 {"format", "csv"}}),
            "(accepted)");
}

TEST(HistoryQueryParse, TimesAreUtc) {
  EXPECT_EQ(parse_time("1970-01-01"), 0);
  EXPECT_EQ(parse_time("1970-01-02T00:00:01Z"), 86'401'000);
  EXPECT_EQ(parse_time("1970-01-01T00:00:00.25Z"), 250);
  EXPECT_FALSE(parse_time("1970-01-01T00:00"));
  EXPECT_FALSE(parse_time("soon"));
}

}  // namespace
}  // namespace lec6::serve::history
