// Issue 32, rule 1: a motion's duration from the completion rule's own polls
// on a virtual timeline, bracketed between the poll before and the poll that
// saw each BUSY edge, read by the history's tracker. A 60 ms move must read
// within its bracket whatever the poll gap (20-80 ms) and phase; the bracket
// is never wider than the gap; a move whose BUSY no poll saw has no duration.

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <random>

#include "lec6/client/completion.hpp"
#include "serve/history/drift.hpp"
#include "serve/history/odometer.hpp"
#include "serve/history/tracker.hpp"

namespace lec6::serve::history {
namespace {

using lec::StatusFlags;

Duration ms(double v) {
  return to_duration(FractionalMilliseconds(v));
}

StatusFlags ready_flags(bool busy, bool inp) {
  StatusFlags f;
  f.set(StatusFlags::Svre, true);
  f.set(StatusFlags::Seton, true);
  f.set(StatusFlags::Busy, busy);
  f.set(StatusFlags::Inp, inp);
  return f;
}

lec::StateData state(int32_t pos, int32_t target) {
  lec::StateData s;
  s.position_001mm = pos;
  s.target_001mm = target;
  return s;
}

nlohmann::json seconds_or_null(const std::optional<Duration>& d) {
  return d ? nlohmann::json(to_seconds(*d)) : nlohmann::json(nullptr);
}

// The finished event as ops/op_results.cpp writes it.
nlohmann::json finished(const client::MoveResult& r) {
  return {{"event", "finished"},
          {"op", "move"},
          {"status", 200},
          {"ok", r.succeeded()},
          {"outcome", std::string(client::outcome_name(r.outcome))},
          {"elapsed_s", to_seconds(r.elapsed)},
          {"timeline",
           {{"busy_up_s", seconds_or_null(r.timeline.busy_up)},
            {"busy_down_s", seconds_or_null(r.timeline.busy_down)},
            {"inp_s", seconds_or_null(r.timeline.inp)},
            {"busy_up_after_s", seconds_or_null(r.timeline.busy_up_after)},
            {"busy_down_after_s", seconds_or_null(r.timeline.busy_down_after)},
            {"inp_after_s", seconds_or_null(r.timeline.inp_after)}}},
          {"target_mm", 100.0}};
}

struct Read {
  MotionRecord record;
  double poll_end_duration_s;  // what the old rule said: start to the first BUSY = 0 poll
};

// One positioning move whose BUSY is up from `rise_ms` to rise_ms + `move_ms`
// after the start's acknowledgement, and whose INP rises `settle_ms` after
// BUSY fell (at the target), polled every `gap_ms` from `phase_ms`.
Read read_move(double rise_ms, double move_ms, double gap_ms, double phase_ms,
               double settle_ms = 0) {
  const TimePoint t0 = TimePoint{} + std::chrono::seconds(10);
  client::MoveGoal goal;
  goal.target_001mm = 10000;
  goal.in_position_001mm = 50;
  client::Completion c({goal, ready_flags(false, true), state(0, 0), false, t0},
                       t0 + std::chrono::seconds(5));
  MotionTracker t("x");
  t.op_event({{"event", "started"}, {"op", "move"}, {"source", "test"}}, t0, 0);
  for (double at = phase_ms;; at += gap_ms) {
    const bool busy = at >= rise_ms && at < rise_ms + move_ms;
    const bool done = at >= rise_ms + move_ms;
    const bool inp = at >= rise_ms + move_ms + settle_ms;
    const auto r = c.feed(
        {ready_flags(busy, inp), done ? state(10000, 10000) : state(5000, 10000), t0 + ms(at)});
    if (r) {
      auto rec = t.op_event(finished(*r), t0 + ms(at), 0);
      EXPECT_TRUE(rec);
      return {*rec, r->timeline.busy_down ? to_seconds(*r->timeline.busy_down) : NAN};
    }
  }
}

TEST(Timing, ASixtyMsMoveReadsWithinItsBracketAtAnyPollGap) {
  std::mt19937 rng(32);
  std::uniform_real_distribution<double> unit(0, 1);
  double worst_old = 0, worst_new = 0;
  for (double gap = 20; gap <= 80; gap += 5) {
    for (int i = 0; i < 200; ++i) {
      const double rise = 2 + 10 * unit(rng);  // the controller's start latency
      const double phase = gap * unit(rng);
      const Read r = read_move(rise, 60, gap, phase);
      const MotionRecord& m = r.record;
      ASSERT_EQ(m.outcome, "reached");
      if (!m.busy_up_s) {  // no poll saw BUSY (a gap near 60 ms can miss it): no duration
        EXPECT_TRUE(std::isnan(m.duration_s)) << "gap " << gap;
        EXPECT_FALSE(m.duration_pm_s);
        continue;
      }
      ASSERT_TRUE(m.duration_pm_s);
      EXPECT_LE(std::abs(m.duration_s - 0.060), *m.duration_pm_s + 1e-9)
          << "gap " << gap << " phase " << phase << ": " << m.duration_s << " ± "
          << *m.duration_pm_s;
      EXPECT_LE(*m.duration_pm_s, gap / 1000 + 1e-9);
      worst_new = std::max(worst_new, std::abs(m.duration_s - 0.060));
      worst_old = std::max(worst_old, std::abs(r.poll_end_duration_s - 0.060));
    }
  }
  // The old reading (start to the first poll that saw BUSY = 0) was off by up
  // to a whole gap plus the start latency; the bracket's middle is closer.
  EXPECT_LT(worst_new, worst_old);
  RecordProperty("worst_error_ms_bracketed", std::to_string(worst_new * 1000));
  RecordProperty("worst_error_ms_poll_end", std::to_string(worst_old * 1000));
}

TEST(Timing, AMoveWhoseBusyNoPollSawHasNoDurationAndAddsNoMotionTime) {
  // 10 ms of BUSY between two polls 40 ms apart, then INP at the target.
  const Read r = read_move(15, 10, 40, 0);
  EXPECT_FALSE(r.record.busy_up_s);
  EXPECT_TRUE(std::isnan(r.record.duration_s));
  Odometer o;
  o.add(r.record);
  EXPECT_EQ(o.moves, 1);
  EXPECT_DOUBLE_EQ(o.motion_s, 0);
  EXPECT_TRUE(to_json(r.record)["duration_s"].is_null());
}

// Rule 5 (issue 32): INP rising after BUSY fell is waited for by the
// completion rule and timed between the polls that bracket both edges: the
// settle time is not 0, and lies within a poll gap of the truth.
TEST(Timing, InpAfterBusyFellGivesASettleTimeWithinItsBracket) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> unit(0, 1);
  for (double gap = 10; gap <= 40; gap += 10) {
    for (int i = 0; i < 100; ++i) {
      const double settle = 60 + 100 * unit(rng);
      const Read r = read_move(5, 300, gap, gap * unit(rng), settle);
      const MotionRecord& m = r.record;
      ASSERT_EQ(m.outcome, "reached") << "INP after BUSY fell is still a reached move";
      ASSERT_TRUE(m.settle_s);
      EXPECT_GT(*m.settle_s, 0);
      EXPECT_LE(std::abs(*m.settle_s - settle / 1000), gap / 1000 + 1e-9)
          << "gap " << gap << ": " << *m.settle_s << " for " << settle << " ms";
    }
  }
}

// The same for a motion only the telemetry saw (another master started it).
TEST(Timing, TelemetrySeesInpAfterBusyFellAsASettleTime) {
  MotionTracker t("x");
  const TimePoint t0 = TimePoint{} + std::chrono::seconds(10);
  std::optional<MotionRecord> rec;
  // BUSY 100-600 ms, INP from 730 ms; flags read every 50 ms from 20 ms.
  for (double at = 20; at < 1500 && !rec; at += 50) {
    const bool busy = at >= 100 && at < 600, inp = at >= 730;
    rec = t.telemetry(at >= 600 ? state(10000, 10000) : state(int32_t(at) * 10, 10000),
                      ready_flags(busy, inp), t0 + ms(at), 0);
  }
  ASSERT_TRUE(rec);
  ASSERT_TRUE(rec->settle_s);
  EXPECT_NEAR(*rec->settle_s, 0.130, 0.050);
  EXPECT_GT(*rec->settle_s, 0.05);
}

// A settle time that grows (a looser axis hunting longer around its target)
// is a drift warning of its own, on timelines of the completion rule.
TEST(Timing, AGrowingSettleTimeRaisesTheSettleWarning) {
  DriftDetector d;
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> unit(0, 1);
  int64_t id = 1;
  bool warned = false;
  for (int i = 0; i < 200 && !warned; ++i) {
    const double settle = (i < 60 ? 120 : 200) + 10 * unit(rng);  // +67 % from move 60
    MotionRecord m = read_move(5, 300, 20, 20 * unit(rng), settle).record;
    m.id = id++;
    m.axis = "x";
    m.start_ms = 1'700'000'000'000 + m.id * 1000;
    for (const auto& e : d.add(m)) {
      if (!e.raised) continue;
      EXPECT_EQ(e.warning.metric, Metric::Settle) << "only the settle time changed";
      EXPECT_GE(i, 60) << "a warning before the settle time grew";
      warned = true;
    }
  }
  EXPECT_TRUE(warned) << "a settle time 67 % longer never warned";
}

// Issue 32's proof on the completion rule's own timelines: one axis' 2 s
// move (0.3 % noise) polled at 25 ms per axis moving on the line (1 to 8,
// changing every 250 moves, random phases and start latencies). A healthy
// axis gives no warning in 10^4 moves; the moves whose bracket is too wide
// at high load are skipped, and counted. +10 % wear is flagged within 50
// moves where durations are judged (1 and 2 moving axes); at 4 and 8 the
// brackets (100-200 ms) are too wide for a 10 % judgement and the duration
// is skipped, not misjudged (thrust still is; docs/history.md). These are
// durations from the brackets alone (a motion without the profile it was
// given: a PLC's); profile_fit_test.cpp has the same proof for the moves
// lec serve runs, dated by their positions, where 4 and 8 axes are judged.
struct LoadRun {
  int first_warning = -1;  // move index of the first duration warning; -1: none
  std::size_t skipped = 0, moves = 0;
};

LoadRun run_under_load(int moves, const std::function<int(int)>& axes_at,
                       const std::function<double(int)>& wear_at, uint32_t seed) {
  DriftDetector d;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> unit(0, 1);
  std::normal_distribution<double> noise(0, 0.003);
  LoadRun out;
  for (int i = 0; i < moves; ++i) {
    const double gap = 25.0 * axes_at(i);
    const double busy = 2000 * (1 + wear_at(i)) * (1 + noise(rng));
    // Drawn in a stated order (an argument list's is unspecified: GCC and
    // clang drew these two the other way round, and gave other runs).
    const double phase_ms = gap * unit(rng);
    const double latency_ms = 2 + 10 * unit(rng);
    MotionRecord m = read_move(latency_ms, busy, gap, phase_ms).record;
    m.id = i + 1;
    m.axis = "x";
    m.start_ms = 1'700'000'000'000 + int64_t(i) * 3000;
    for (const auto& e : d.add(m)) {
      if (e.raised && e.warning.metric == Metric::Duration && out.first_warning < 0)
        out.first_warning = i;
    }
  }
  for (const auto& g : d.groups("x")) {
    out.skipped += g.skipped_duration;
    out.moves += g.moves;
  }
  return out;
}

TEST(Timing, AHealthyAxisUnderALoadOfOneToEightAxesNeverWarnsInTenThousandMoves) {
  const int loads[] = {1, 2, 4, 8, 4, 2};
  const LoadRun r = run_under_load(
      10'000, [&](int i) { return loads[(i / 250) % 6]; }, [](int) { return 0.0; }, 11);
  EXPECT_EQ(r.first_warning, -1) << "a false warning at move " << r.first_warning;
  EXPECT_EQ(r.moves, 10'000u);
  EXPECT_GT(r.skipped, 2'000u) << "the wide brackets of 4 and 8 axes are skipped";
  EXPECT_LT(r.skipped, 8'000u) << "those of 1 and 2 axes are judged";
  RecordProperty("durations_skipped", std::to_string(r.skipped));
}

TEST(Timing, TenPercentWearIsFlaggedWithinFiftyMovesWhereDurationsAreJudged) {
  for (int axes : {1, 2}) {
    // A baseline on a quiet line, then this load, then +10 % wear from move 300.
    const LoadRun r = run_under_load(
        400, [&](int i) { return i < 100 ? 1 : axes; }, [](int i) { return i < 300 ? 0.0 : 0.10; },
        20 + axes);
    EXPECT_GE(r.first_warning, 300) << axes << " axes: a warning before the wear";
    EXPECT_LE(r.first_warning, 350) << axes << " axes: +10 % not flagged within 50 moves";
  }
  for (int axes : {4, 8}) {  // too wide to judge: skipped, never a false warning
    const LoadRun r = run_under_load(
        400, [&](int i) { return i < 100 ? 1 : axes; }, [](int i) { return i < 300 ? 0.0 : 0.10; },
        30 + axes);
    EXPECT_EQ(r.first_warning, -1) << axes << " axes";
    EXPECT_GE(r.skipped, 250u) << axes << " axes: most are skipped";
  }
}

}  // namespace
}  // namespace lec6::serve::history
