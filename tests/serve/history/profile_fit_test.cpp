// Issue 32, rule 1 under load: a motion dated by its position samples
// against the profile it was given (serve/history/profile_fit.hpp). The
// motions are the twin's own kinematics (sim::MotionProfile, digest §6), so
// the fit is checked against another implementation of the trapezoid; the
// polls come at the gap a line of 1 to 8 moving axes leaves each (25 ms per
// axis at 38400: a state read and a flags read), at random phases.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <functional>
#include <memory>
#include <random>

#include "lec6/client/completion.hpp"
#include "lec6/sim/motion_profile.hpp"
#include "sanitized.hpp"
#include "serve/history/drift.hpp"
#include "serve/history/profile_fit.hpp"
#include "serve/history/tracker.hpp"

namespace lec6::serve::history {
namespace profile_fit_test {

using lec::StatusFlags;
using lec6::testing::kSanitized;
using lec6::testing::sanitized;
// The CPU-bound cases walk a tenth of their cases under the sanitizers
// (tests/sanitized.hpp); the optimised tree walks them all.
constexpr int kFew = kSanitized ? 10 : 1;

Duration msecs(double v) {
  return to_duration(FractionalMilliseconds(v));
}

// One motion of the twin: BUSY up `busy_delay_ms` after the start, the
// profile from then to its end (the twin's BUSY).
struct Motion {
  double from_mm = 50, to_mm = 250, speed = 100, accel = 1000, decel = 1000;
  double wear = 0;  // the twin's wear: the cruise speed divided by 1 + wear
  double busy_delay_ms = 20;
  sim::MotionProfile profile(TimePoint start) const {
    return sim::MotionProfile::plan(start + msecs(busy_delay_ms), from_mm, 0, to_mm,
                                    {speed / (1 + wear), accel, decel});
  }
};

// A poll: its query goes out at `t`, the controller samples 3 ms later, the
// reply is complete at 8 ms (a state read of 7 registers at 38400).
struct Polled {
  MotionRecord record;
  double true_s = 0;
};

// Any motion: position(t) and BUSY [rise, fall), polled every `gap_ms`
// from `phase_ms`, fed to `tracker` and to the completion rule as lec serve does; the
// finished event as ops/op_results.cpp writes it. `start_sample_mm`: the
// telemetry's last sample before the start (NaN: where it stood).
struct Truth {
  std::function<double(TimePoint)> pos;
  TimePoint rise, fall;
  double from_mm, to_mm;
};
struct Asked {
  double speed, accel, decel;
};

Polled poll_truth(MotionTracker& tracker, const Truth& tr, TimePoint t0, const Asked& asked,
                  double gap_ms, double phase_ms, double start_sample_mm = NAN,
                  bool with_profile = true) {
  client::MoveGoal goal;
  goal.target_001mm = static_cast<int32_t>(std::lround(tr.to_mm * 100));
  goal.in_position_001mm = 50;
  lec::StateData before;
  before.position_001mm = static_cast<int32_t>(
      std::lround((std::isnan(start_sample_mm) ? tr.from_mm : start_sample_mm) * 100));
  before.target_001mm = before.position_001mm;
  StatusFlags idle;
  idle.set(StatusFlags::Svre, true);
  idle.set(StatusFlags::Seton, true);
  idle.set(StatusFlags::Inp, true);
  client::Completion c({goal, idle, before, false, t0}, t0 + std::chrono::seconds(60));
  tracker.telemetry(before, idle, t0 - msecs(50), 0, t0 - msecs(58));
  tracker.op_event({{"event", "started"}, {"op", "move"}, {"source", "test"}}, t0, 0);
  for (double at = phase_ms;; at += gap_ms) {
    const TimePoint sent = t0 + msecs(at), sampled = sent + msecs(3), end = sent + msecs(8);
    lec::StateData s;
    s.position_001mm = static_cast<int32_t>(std::lround(tr.pos(sampled) * 100));
    s.target_001mm = goal.target_001mm;
    StatusFlags f = idle;
    const bool busy = sampled >= tr.rise && sampled < tr.fall;
    f.set(StatusFlags::Busy, busy);
    f.set(StatusFlags::Inp, sampled >= tr.fall);
    tracker.telemetry(s, f, end, 0, sent);
    if (const auto r = c.feed({f, s, end, sent})) {
      nlohmann::json e{{"event", "finished"},
                       {"op", "move"},
                       {"status", 200},
                       {"ok", r->succeeded()},
                       {"outcome", std::string(client::outcome_name(r->outcome))},
                       {"target_mm", tr.to_mm},
                       {"position_mm", tr.to_mm}};
      const auto sec = [](const std::optional<Duration>& d) {
        return d ? nlohmann::json(to_seconds(*d)) : nlohmann::json(nullptr);
      };
      e["timeline"] = {{"busy_up_s", sec(r->timeline.busy_up)},
                       {"busy_down_s", sec(r->timeline.busy_down)},
                       {"inp_s", sec(r->timeline.inp)},
                       {"busy_up_after_s", sec(r->timeline.busy_up_after)},
                       {"busy_down_after_s", sec(r->timeline.busy_down_after)},
                       {"inp_after_s", sec(r->timeline.inp_after)},
                       {"origin_ns", std::chrono::duration_cast<std::chrono::nanoseconds>(
                                         r->timeline.origin.time_since_epoch())
                                         .count()}};
      if (with_profile)
        e["profile"] = {{"from_mm", tr.from_mm},
                        {"speed_mm_s", asked.speed},
                        {"acceleration_mm_s2", asked.accel},
                        {"deceleration_mm_s2", asked.decel}};
      auto rec = tracker.op_event(e, end, 0);
      EXPECT_TRUE(rec);
      return {rec ? *rec : MotionRecord{}, to_seconds(tr.fall - tr.rise)};
    }
  }
}

Polled poll_motion(MotionTracker& tracker, const Motion& mo, double gap_ms, double phase_ms,
                   bool with_profile = true) {
  const TimePoint t0 = TimePoint{} + std::chrono::seconds(10);
  const sim::MotionProfile p = mo.profile(t0);
  Truth tr{[p](TimePoint t) { return p.position(t); }, p.start_time(), p.end_time(), mo.from_mm,
           mo.to_mm};
  return poll_truth(tracker, tr, t0, {mo.speed, mo.accel, mo.decel}, gap_ms, phase_ms, NAN,
                    with_profile);
}

// The first moves of a setting are timed by the polls: the offset the fit
// cannot see (fit_offsets.hpp) is not pinned down yet.
TEST(ProfileFit, AMotionAtAnyPollGapIsTimedWithinItsBoundAndNarrowerThanThePolls) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> unit(0, 1);
  for (int axes : {1, 2, 4, 8}) {
    const double gap = 25.0 * axes;
    double worst_pm = 0;
    int by_positions = 0;
    MotionTracker tracker("x");
    for (int i = 0; i < 100; ++i) {
      Motion mo;
      mo.wear = 0.2 * unit(rng);
      if (i % 2 == 1) std::swap(mo.from_mm, mo.to_mm);
      const Polled p = poll_motion(tracker, mo, gap, gap * unit(rng));
      const MotionRecord& r = p.record;
      ASSERT_TRUE(r.duration_pm_s);
      EXPECT_LE(std::abs(r.duration_s - p.true_s), *r.duration_pm_s + 1e-9)
          << axes << " axes, move " << i << ": " << r.duration_s << " ± " << *r.duration_pm_s
          << " (" << r.timed_by << "), true " << p.true_s;
      if (r.timed_by != "positions") continue;
      ++by_positions;
      if (i >= 20) worst_pm = std::max(worst_pm, *r.duration_pm_s);
    }
    EXPECT_GE(by_positions, 80) << axes << " axes";
    // After 20 moves, judged by the drift detector (± ≤ 2.5 % of ~2 s) at 1
    // to 4 moving axes; at 8 the ± narrows more slowly (docs/history.md).
    if (axes <= 4) {
      EXPECT_LT(worst_pm, 0.025 * 2.0) << axes << " axes";
    }
    RecordProperty("worst_pm_ms_" + std::to_string(axes), std::to_string(worst_pm * 1000));
  }
}

TEST(ProfileFit, WithoutTheProfileTheBracketsStand) {
  MotionTracker tracker("x");
  const Polled p = poll_motion(tracker, Motion{}, 200, 77, false);
  EXPECT_EQ(p.record.timed_by, "polls");
  EXPECT_LE(std::abs(p.record.duration_s - p.true_s), *p.record.duration_pm_s + 1e-9);
}

ProfileSample at(const sim::MotionProfile& p, double t_s, double window_s = 0.004) {
  return {t_s, window_s, p.position(TimePoint{} + to_duration(FractionalSeconds(t_s)))};
}

TEST(ProfileFit, TwoSamplesInMotionAreNotEnough) {
  const auto p = sim::MotionProfile::plan(TimePoint{}, 0, 0, 200, {100, 1000, 1000});
  EXPECT_FALSE(fit_profile({at(p, 0.0), at(p, 1.0), at(p, 3.0)}, {0, 200, 100, 1000, 1000}));
  // Two always admit some speed; a third must agree with them.
  EXPECT_FALSE(fit_profile({at(p, 0.5), at(p, 1.5)}, {0, 200, 100, 1000, 1000}));
  EXPECT_TRUE(fit_profile({at(p, 0.5), at(p, 1.0), at(p, 1.5)}, {0, 200, 100, 1000, 1000}));
}

TEST(ProfileFit, SamplesOfAnotherMotionAreRefused) {
  // Retargeted past the target: a sample beyond it.
  const auto far = sim::MotionProfile::plan(TimePoint{}, 0, 0, 300, {100, 1000, 1000});
  EXPECT_FALSE(fit_profile({at(far, 0.5), at(far, 1.5), at(far, 2.5)}, {0, 200, 100, 1000, 1000}));
  // Held half a second mid-way (BUSY stays up): the samples cannot agree.
  const auto first = sim::MotionProfile::plan(TimePoint{}, 0, 0, 100, {100, 1000, 1000});
  const double resume_s = to_seconds(first.end_time() - TimePoint{}) + 0.5;
  const auto second = sim::MotionProfile::plan(
      TimePoint{} + to_duration(FractionalSeconds(resume_s)), 100, 0, 200, {100, 1000, 1000});
  std::vector<ProfileSample> held;
  for (double t = 0.1; t < resume_s + 1.2; t += 0.1)
    held.push_back(t < resume_s ? at(first, t) : at(second, t));
  EXPECT_FALSE(fit_profile(held, {0, 200, 100, 1000, 1000}));
  // A controller that crept at a fifth of the speed: not pinned down here.
  const auto slow = sim::MotionProfile::plan(TimePoint{}, 0, 0, 200, {20, 1000, 1000});
  EXPECT_FALSE(fit_profile({at(slow, 1.0), at(slow, 2.0)}, {0, 200, 100, 1000, 1000}));
}

// Feeds move `i` to the detector; returns the index of the first duration
// warning so far (`first`, or i if this move raised one; -1: none yet).
int add_move(DriftDetector& d, MotionRecord r, int i, int first) {
  r.id = i + 1;
  r.axis = "x";
  r.start_ms = 1'700'000'000'000 + int64_t(i) * 3000;
  for (const auto& e : d.add(r))
    if (e.raised && e.warning.metric == Metric::Duration && first < 0) first = i;
  return first;
}

// Issue 32's proof through the tracker: the axis' durations feed the drift
// detector while 1 to 8 axes move on its line. A healthy axis never warns in
// 10^4 moves as the load changes; +10 % wear is flagged within 50 moves at
// every load.
int first_duration_warning(int moves, const std::function<int(int)>& axes_at,
                           const std::function<double(int)>& wear_at, uint32_t seed,
                           std::size_t* skipped = nullptr) {
  DriftDetector d;
  MotionTracker tracker("x");
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> unit(0, 1);
  std::normal_distribution<double> noise(0, 0.003);
  int first = -1;
  for (int i = 0; i < moves; ++i) {
    const double gap = 25.0 * axes_at(i);
    Motion mo;
    mo.wear = wear_at(i) + std::abs(noise(rng));  // never faster than asked
    mo.busy_delay_ms = 15 + 10 * unit(rng);
    const double phase = gap * unit(rng);
    MotionRecord r = poll_motion(tracker, mo, gap, phase).record;
    first = add_move(d, r, i, first);
  }
  if (skipped)
    for (const auto& g : d.groups("x")) *skipped += g.skipped_duration;
  return first;
}

TEST(ProfileFit, AHealthyAxisUnderALoadOfOneToEightAxesNeverWarnsInTenThousandMoves) {
  const int loads[] = {1, 2, 4, 8, 4, 2};
  std::size_t skipped = 0;
  const int first = first_duration_warning(
      sanitized(10'000, 600), [&](int i) { return loads[(i / 250) % 6]; }, [](int) { return 0.0; },
      11, &skipped);
  EXPECT_EQ(first, -1) << "a false warning at move " << first;
  EXPECT_LT(skipped, 1'000u) << "durations skipped: the fit should judge most";
  RecordProperty("durations_skipped", std::to_string(skipped));
}

// The twin's wear lowers the cruise speed; the wear that makes this move
// 10 % longer.
double ten_percent_longer() {
  const Motion mo;
  const double want = 1.10 * trapezoid_duration_s(200, mo.speed, mo.accel, mo.decel);
  double lo = 0, hi = 1;
  for (int i = 0; i < 60; ++i) {
    const double w = (lo + hi) / 2;
    (trapezoid_duration_s(200, mo.speed / (1 + w), mo.accel, mo.decel) < want ? lo : hi) = w;
  }
  return lo;
}

TEST(ProfileFit, TenPercentWearIsFlaggedWithinFiftyMovesAtEveryLoad) {
  const double wear = ten_percent_longer();
  for (int axes : kSanitized ? std::vector<int>{8} : std::vector<int>{1, 2, 4, 8}) {
    // A baseline on a quiet line, then this load, then +10 % wear from move 300.
    const int first = first_duration_warning(
        400, [&](int i) { return i < 100 ? 1 : axes; }, [&](int i) { return i < 300 ? 0.0 : wear; },
        40 + axes);
    EXPECT_GE(first, 300) << axes << " axes: a warning before the wear";
    EXPECT_LE(first, 350) << axes << " axes: +10 % not flagged within 50 moves";
  }
}

// One tracker per case (its fit offsets are learned across the moves of
// a case, as lec serve's are across an axis' moves).
std::unique_ptr<MotionTracker>& attack_tracker_slot() {
  static std::unique_ptr<MotionTracker> t;
  return t;
}
MotionTracker& attack_tracker() {
  auto& t = attack_tracker_slot();
  if (!t) t = std::make_unique<MotionTracker>("x");
  return *t;
}
void fresh_attack_tracker() {
  attack_tracker_slot().reset();
}

struct Tally {
  int n = 0, by_pos = 0, outside = 0;
  double worst_err = 0, worst_pm = 0, worst_excess = 0;
  void add(const Polled& p) {
    ++n;
    const MotionRecord& r = p.record;
    if (r.timed_by != "positions") return;
    ++by_pos;
    const double err = std::abs(r.duration_s - p.true_s);
    if (err > *r.duration_pm_s + 1e-9) {
      ++outside;
      if (err - *r.duration_pm_s > worst_excess) {
        worst_excess = err - *r.duration_pm_s;
        worst_err = err;
        worst_pm = *r.duration_pm_s;
      }
    }
  }
  std::string str() const {
    return "moves " + std::to_string(n) + ", timed by positions " + std::to_string(by_pos) +
           ", true duration outside ± " + std::to_string(outside) + ", worst err " +
           std::to_string(worst_err * 1e3) + " ms with ± " + std::to_string(worst_pm * 1e3) + " ms";
  }
};

// A1: the actuator's acceleration limit (twin: max_accel_mm_s2 = 10000, a
// step's acceleration above it is clamped, behaviour.hpp) – the controller
// runs another trapezoid than the one written.
TEST(ProfileFitAttacked, AccelClampedByTheActuatorIsNotRefused) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> unit(0, 1);
  for (int axes : kSanitized ? std::vector<int>{8} : std::vector<int>{1, 2, 4, 8}) {
    Tally t;
    fresh_attack_tracker();
    for (int i = 0; i < 100 / kFew; ++i) {
      const TimePoint t0 = TimePoint{} + std::chrono::seconds(10);
      const auto p = sim::MotionProfile::plan(t0 + msecs(20), 0, 0, 1000, {500, 10000, 10000});
      Truth tr{[p](TimePoint t) { return p.position(t); }, p.start_time(), p.end_time(), 0, 1000};
      t.add(poll_truth(attack_tracker(), tr, t0, {500, 30000, 30000}, 25.0 * axes,
                       25.0 * axes * unit(rng)));
    }
    EXPECT_EQ(t.outside, 0) << axes << " axes: " << t.str();
  }
}

// A2: a hold mid-move (HOLD from a PLC: BUSY stays 1, R-FLAG-HOLD) on a short
// move under load: few samples, and two of them explain a slower speed.
TEST(ProfileFitAttacked, AHoldSeenByFewSamplesIsNotRefused) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> unit(0, 1);
  for (int axes : {4, 8}) {
    Tally t;
    fresh_attack_tracker();
    for (int i = 0; i < 200; ++i) {
      const TimePoint t0 = TimePoint{} + std::chrono::seconds(10);
      const auto a = sim::MotionProfile::plan(t0 + msecs(20), 0, 0, 40, {100, 1000, 1000});
      const TimePoint resume = a.end_time() + msecs(120);
      const auto b = sim::MotionProfile::plan(resume, 40, 0, 80, {100, 1000, 1000});
      Truth tr{[a, b, resume](TimePoint t) { return t < resume ? a.position(t) : b.position(t); },
               a.start_time(), b.end_time(), 0, 80};
      t.add(poll_truth(attack_tracker(), tr, t0, {100, 1000, 1000}, 25.0 * axes,
                       25.0 * axes * unit(rng)));
    }
    EXPECT_EQ(t.outside, 0) << axes << " axes: " << t.str();
  }
}

// A2b: fit_profile alone, the hold of SamplesOfAnotherMotionAreRefused seen
// by two samples.
TEST(ProfileFitAttacked, HoldTwoSamples) {
  const auto first = sim::MotionProfile::plan(TimePoint{}, 0, 0, 100, {100, 1000, 1000});
  const double resume_s = to_seconds(first.end_time() - TimePoint{}) + 0.5;
  const auto second = sim::MotionProfile::plan(
      TimePoint{} + to_duration(FractionalSeconds(resume_s)), 100, 0, 200, {100, 1000, 1000});
  const double true_s = to_seconds(second.end_time() - TimePoint{});
  const auto fit = fit_profile({at(first, -0.5), at(first, 0.5), at(second, 2.0), at(second, 3.5)},
                               {0, 200, 100, 1000, 1000});
  EXPECT_FALSE(fit) << "hold accepted: " << (fit ? fit->duration_s : 0) << " s, true " << true_s;
}

// A3: the speed grid's step at slow fitted speeds is wider than the step_s
// the ± adds (1/1500 of v, while the grid's is 0.76/1500 of the written).
// Samples taken anywhere inside their windows (the promise), exact positions.
TEST(ProfileFitAttacked, GridStepAtSlowSpeeds) {
  std::mt19937 rng(21);
  std::uniform_real_distribution<double> unit(0, 1);
  int outside = 0, fitted = 0, n = 0;
  double worst = 0, worst_pm = 0, worst_f = 0, worst_D = 0;
  for (int k = 0; k < 4000 / kFew; ++k) {
    const double f = 0.26 + 0.74 * unit(rng);
    const double D = 20 + 400 * unit(rng);
    const double w = 0.004 * unit(rng);
    const double gap = 0.025 * (1 + 7 * unit(rng));
    const auto p = sim::MotionProfile::plan(TimePoint{}, 0, 0, D, {100 * f, 1000, 1000});
    const double true_s = to_seconds(p.end_time() - TimePoint{});
    std::vector<ProfileSample> xs;
    for (double t = -0.1 + gap * unit(rng); t < true_s + 0.2; t += gap) {
      const double taken = t + w * (2 * unit(rng) - 1);
      xs.push_back({t, w, p.position(TimePoint{} + to_duration(FractionalSeconds(taken)))});
    }
    ++n;
    const auto fit = fit_profile(xs, {0, D, 100, 1000, 1000});
    if (!fit) continue;
    ++fitted;
    const double err = std::abs(fit->duration_s - true_s);
    if (err > fit->pm_s + 1e-9) {
      ++outside;
      if (err - fit->pm_s > worst - worst_pm)
        worst = err, worst_pm = fit->pm_s, worst_f = f, worst_D = D;
    }
  }
  EXPECT_EQ(outside, 0) << "fitted " << fitted << "/" << n << ", outside ± " << outside
                        << ", worst err " << worst * 1e3 << " ms ± " << worst_pm * 1e3
                        << " ms at f=" << worst_f << " D=" << worst_D;
}

// A4: a stale start position: the axis stands 3 mm further on than the last
// telemetry sample said (pushed by hand with the servo off, jogged from the
// teaching box between polls...).
TEST(ProfileFitAttacked, StaleStartPosition) {
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> unit(0, 1);
  for (int axes : {1, 4, 8}) {
    Tally t;
    fresh_attack_tracker();
    for (int i = 0; i < 100 / kFew; ++i) {
      const TimePoint t0 = TimePoint{} + std::chrono::seconds(10);
      const auto p = sim::MotionProfile::plan(t0 + msecs(20), 53, 0, 250, {100, 1000, 1000});
      Truth tr{[p](TimePoint t) { return p.position(t); }, p.start_time(), p.end_time(), 53, 250};
      t.add(poll_truth(attack_tracker(), tr, t0, {100, 1000, 1000}, 25.0 * axes,
                       25.0 * axes * unit(rng), 50.0));
    }
    EXPECT_EQ(t.outside, 0) << axes << " axes: " << t.str();
  }
}

// A5: BUSY held past the profile's end (in-position settling, documented as
// an assumption): how far off.
TEST(ProfileFitAttacked, BusyHeldPastTheProfile) {
  std::mt19937 rng(13);
  std::uniform_real_distribution<double> unit(0, 1);
  for (int axes : {1, 8}) {
    Tally t;
    fresh_attack_tracker();
    for (int i = 0; i < 100 / kFew; ++i) {
      const TimePoint t0 = TimePoint{} + std::chrono::seconds(10);
      const auto p = sim::MotionProfile::plan(t0 + msecs(20), 50, 0, 250, {100, 1000, 1000});
      Truth tr{[p](TimePoint t) { return p.position(t); }, p.start_time(), p.end_time() + msecs(30),
               50, 250};
      t.add(poll_truth(attack_tracker(), tr, t0, {100, 1000, 1000}, 25.0 * axes,
                       25.0 * axes * unit(rng)));
    }
    EXPECT_EQ(t.outside, 0) << axes << " axes: " << t.str();
  }
}

// A6: an S-curve (jerk-limited: the trapezoid averaged over 60 ms).
TEST(ProfileFitAttacked, SCurve) {
  std::mt19937 rng(17);
  std::uniform_real_distribution<double> unit(0, 1);
  for (int axes : kSanitized ? std::vector<int>{8} : std::vector<int>{1, 2, 4, 8}) {
    Tally t;
    fresh_attack_tracker();
    for (int i = 0; i < 100 / kFew; ++i) {
      const TimePoint t0 = TimePoint{} + std::chrono::seconds(10);
      const auto p = sim::MotionProfile::plan(t0 + msecs(20), 50, 0, 250, {100, 1000, 1000});
      const double J = 0.060;
      auto pos = [p, J](TimePoint t) {
        double s = 0;
        for (int k = 0; k < 60; ++k)
          s += p.position(t - to_duration(FractionalSeconds(J * (k + 0.5) / 60)));
        return s / 60;
      };
      Truth tr{pos, p.start_time(), p.end_time() + to_duration(FractionalSeconds(J)), 50, 250};
      t.add(poll_truth(attack_tracker(), tr, t0, {100, 1000, 1000}, 25.0 * axes,
                       25.0 * axes * unit(rng)));
    }
    EXPECT_EQ(t.outside, 0) << axes << " axes: " << t.str();
  }
}

sim::MotionProfile plan_at(TimePoint t, double from, double to, double v, double a) {
  return sim::MotionProfile::plan(t, from, 0, to, {v, a, a});
}

std::function<double(TimePoint)> smoothed(const sim::MotionProfile& p, double J) {
  return [p, J](TimePoint t) {
    double s = 0;
    for (int k = 0; k < 60; ++k)
      s += p.position(t - to_duration(FractionalSeconds(J * (k + 0.5) / 60)));
    return s / 60;
  };
}

// A2c: holds of any length anywhere, through the tracker.
TEST(ProfileFitAttacked, HoldScanThroughTheTracker) {
  std::mt19937 rng(23);
  std::uniform_real_distribution<double> unit(0, 1);
  for (int axes : {2, 4, 8}) {
    Tally t;
    fresh_attack_tracker();
    for (int i = 0; i < 500 / kFew; ++i) {
      const TimePoint t0 = TimePoint{} + std::chrono::seconds(10);
      const double D = 20 + 200 * unit(rng), h = 0.2 + 0.6 * unit(rng);
      const double H = 0.03 + 0.3 * unit(rng);
      const auto a = plan_at(t0 + msecs(20), 0, D * h, 100, 1000);
      const TimePoint resume = a.end_time() + to_duration(FractionalSeconds(H));
      const auto b = plan_at(resume, D * h, D, 100, 1000);
      Truth tr{[a, b, resume](TimePoint t) { return t < resume ? a.position(t) : b.position(t); },
               a.start_time(), b.end_time(), 0, D};
      t.add(poll_truth(attack_tracker(), tr, t0, {100, 1000, 1000}, 25.0 * axes,
                       25.0 * axes * unit(rng)));
    }
    EXPECT_EQ(t.outside, 0) << axes << " axes: " << t.str();
  }
}

// A6b: S-curve of a smaller jerk time.
TEST(ProfileFitAttacked, SCurveSmallJ) {
  std::mt19937 rng(29);
  std::uniform_real_distribution<double> unit(0, 1);
  for (double J : {0.010, 0.020, 0.040}) {
    for (int axes : {1, 8}) {
      Tally t;
      fresh_attack_tracker();
      for (int i = 0; i < 100 / kFew; ++i) {
        const TimePoint t0 = TimePoint{} + std::chrono::seconds(10);
        const auto p = plan_at(t0 + msecs(20), 50, 250, 100, 1000);
        Truth tr{smoothed(p, J), p.start_time(), p.end_time() + to_duration(FractionalSeconds(J)),
                 50, 250};
        t.add(poll_truth(attack_tracker(), tr, t0, {100, 1000, 1000}, 25.0 * axes,
                         25.0 * axes * unit(rng)));
      }
      EXPECT_EQ(t.outside, 0) << "J " << J * 1e3 << " ms, " << axes << " axes: " << t.str();
    }
  }
}

// A7: drift detector, healthy S-curve axis (J = 120 ms), 1 s move; baseline
// learned at 8 moving axes, then the line quiets down to 1.
TEST(ProfileFitAttacked, DriftFalseWarningWhenLoadDrops) {
  for (const auto& loads : kSanitized
                               ? std::vector<std::pair<int, int>>{{8, 1}}
                               : std::vector<std::pair<int, int>>{{8, 1}, {1, 8}, {8, 2}, {4, 1}}) {
    DriftDetector d;
    fresh_attack_tracker();
    std::mt19937 rng(31);
    std::uniform_real_distribution<double> unit(0, 1);
    std::normal_distribution<double> noise(0, 0.003);
    int first = -1, by_pos_lo = 0, by_pos_hi = 0;
    for (int i = 0; i < 300; ++i) {
      const int axes = i < 100 ? loads.first : loads.second;
      const double gap = 25.0 * axes;
      const TimePoint t0 = TimePoint{} + std::chrono::seconds(10);
      const double J = 0.12;
      const auto p =
          plan_at(t0 + msecs(15 + 10 * unit(rng)), 50, 150, 100 / (1 + std::abs(noise(rng))), 1000);
      Truth tr{smoothed(p, J), p.start_time(), p.end_time() + to_duration(FractionalSeconds(J)), 50,
               150};
      MotionRecord r =
          poll_truth(attack_tracker(), tr, t0, {100, 1000, 1000}, gap, gap * unit(rng)).record;
      (i < 100 ? by_pos_hi : by_pos_lo) += r.timed_by == "positions";
      first = add_move(d, r, i, first);
    }
    EXPECT_EQ(first, -1) << loads.first << " then " << loads.second
                         << " axes: first warning at move " << first
                         << " (load changes at 100); timed by positions " << by_pos_hi
                         << "/100 then " << by_pos_lo << "/200";
  }
}

TEST(ProfileFitAttacked, DriftFalseWarningWhenLoadDrops2) {
  for (double J : kSanitized ? std::vector<double>{0.13} : std::vector<double>{0.08, 0.13}) {
    for (double D : kSanitized ? std::vector<double>{110.0} : std::vector<double>{90.0, 110.0}) {
      DriftDetector d;
      fresh_attack_tracker();
      std::mt19937 rng(37);
      std::uniform_real_distribution<double> unit(0, 1);
      std::normal_distribution<double> noise(0, 0.003);
      int first = -1, by_pos_hi = 0, by_pos_lo = 0;
      std::size_t skipped = 0;
      for (int i = 0; i < 600; ++i) {
        const int axes = i < 300 ? 8 : 1;
        const double gap = 25.0 * axes;
        const TimePoint t0 = TimePoint{} + std::chrono::seconds(10);
        const auto p = plan_at(t0 + msecs(15 + 10 * unit(rng)), 50, 50 + D,
                               100 / (1 + std::abs(noise(rng))), 1000);
        Truth tr{smoothed(p, J), p.start_time(), p.end_time() + to_duration(FractionalSeconds(J)),
                 50, 50 + D};
        MotionRecord r =
            poll_truth(attack_tracker(), tr, t0, {100, 1000, 1000}, gap, gap * unit(rng)).record;
        (i < 300 ? by_pos_hi : by_pos_lo) += r.timed_by == "positions";
        first = add_move(d, r, i, first);
      }
      for (const auto& g : d.groups("x")) skipped += g.skipped_duration;
      EXPECT_EQ(first, -1) << "J " << J * 1e3 << " ms, D " << D << ": first warning at " << first
                           << " (8 axes then 1 at 300); by positions " << by_pos_hi << "/300, "
                           << by_pos_lo << "/300; skipped " << skipped;
    }
  }
}

// Healthy sweep: trapezoid exactly as written, slow/fast, short/long, a != d.
TEST(ProfileFitAttacked, HealthySweep) {
  std::mt19937 rng(41);
  std::uniform_real_distribution<double> unit(0, 1);
  for (double v : {1.0, 2.0, 5.0, 20.0, 100.0, 500.0}) {
    for (auto ad : std::vector<std::pair<double, double>>{
             {1000, 1000}, {50, 50}, {3000, 200}, {200, 3000}, {1, 1}}) {
      Tally t;
      fresh_attack_tracker();
      for (int i = 0; i < 30 / kFew; ++i) {
        const int axes = 1 << int(4 * unit(rng));
        const double D = std::min(0.2 + std::pow(10, 3 * unit(rng)), v * 20);
        const double wear = 0.2 * unit(rng);
        const double from = 50 + 100 * unit(rng);
        const double to = unit(rng) < 0.5 ? from + D : from - std::min(D, from - 0.5);
        const TimePoint t0 = TimePoint{} + std::chrono::seconds(10);
        const auto p = sim::MotionProfile::plan(t0 + msecs(20), from, 0, to,
                                                {v / (1 + wear), ad.first, ad.second});
        Truth tr{[p](TimePoint t) { return p.position(t); }, p.start_time(), p.end_time(), from,
                 to};
        t.add(poll_truth(attack_tracker(), tr, t0, {v, ad.first, ad.second}, 25.0 * axes,
                         25.0 * axes * unit(rng)));
      }
      EXPECT_EQ(t.outside, 0) << "v " << v << " a " << ad.first << " d " << ad.second << ": "
                              << t.str();
    }
  }
}

// Slow moves: D9000 is in 0.01 mm; at 1 mm/s that is up to 5 ms, not in the windows.
TEST(ProfileFitAttacked, SlowMoveQuantization) {
  for (bool rounded : {false, true}) {
    std::mt19937 rng(43);
    std::uniform_real_distribution<double> unit(0, 1);
    int fitted = 0, outside = 0;
    double worst = 0, worst_pm = 0;
    for (int i = 0; i < 300 / kFew; ++i) {
      const double D = 2 + 10 * unit(rng), wear = 0.2 * unit(rng),
                   gap = 0.025 * (1 + 7 * unit(rng));
      const auto p = sim::MotionProfile::plan(TimePoint{}, 0, 0, D, {1.0 / (1 + wear), 50, 50});
      const double true_s = to_seconds(p.end_time() - TimePoint{});
      std::vector<ProfileSample> xs;
      for (double t = -0.1 + gap * unit(rng); t < true_s + 0.3; t += gap) {
        // the controller samples 3 ms into an 8 ms read, as in poll_motion
        double x = p.position(TimePoint{} + to_duration(FractionalSeconds(t - 0.001)));
        if (rounded) x = std::round(x * 100) / 100;
        xs.push_back({t, 0.004, x});
      }
      const auto fit = fit_profile(xs, {0, D, 1, 50, 50});
      if (!fit) continue;
      ++fitted;
      const double err = std::abs(fit->duration_s - true_s);
      if (err > fit->pm_s) {
        ++outside;
        if (err - fit->pm_s > worst - worst_pm) worst = err, worst_pm = fit->pm_s;
      }
    }
    EXPECT_EQ(outside, 0) << (rounded ? "0.01 mm positions: " : "exact positions: ") << "fitted "
                          << fitted << "/300, outside ± " << outside << ", worst " << worst * 1e3
                          << " ms ± " << worst_pm * 1e3 << " ms";
  }
}

// Wear that lowers the acceleration the drive reaches (not the cruise speed):
// +10 % duration from move 300.
TEST(ProfileFitAttacked, WearThatLowersAcceleration) {
  for (int axes : kSanitized ? std::vector<int>{8} : std::vector<int>{1, 2, 4, 8}) {
    DriftDetector d;
    fresh_attack_tracker();
    std::mt19937 rng(40 + axes);
    std::uniform_real_distribution<double> unit(0, 1);
    std::normal_distribution<double> noise(0, 0.003);
    int first = -1, by_pos_after = 0;
    std::size_t skipped = 0;
    for (int i = 0; i < 400; ++i) {
      const int ax = i < 100 ? 1 : axes;
      const double gap = 25.0 * ax;
      const double a = i < 300 ? 1000 : 322;
      const TimePoint t0 = TimePoint{} + std::chrono::seconds(10);
      const auto p = sim::MotionProfile::plan(t0 + msecs(15 + 10 * unit(rng)), 50, 0, 250,
                                              {100 / (1 + std::abs(noise(rng))), a, a});
      Truth tr{[p](TimePoint t) { return p.position(t); }, p.start_time(), p.end_time(), 50, 250};
      MotionRecord r =
          poll_truth(attack_tracker(), tr, t0, {100, 1000, 1000}, gap, gap * unit(rng)).record;
      if (i >= 300) by_pos_after += r.timed_by == "positions";
      first = add_move(d, r, i, first);
    }
    for (const auto& g : d.groups("x")) skipped += g.skipped_duration;
    EXPECT_TRUE(first == -1 || first >= 300)
        << axes << " axes: first warning " << first << " (wear from 300); after wear "
        << by_pos_after << "/100 timed by positions; skipped " << skipped;
  }
}

// A servo's following error: the carriage lags the commanded trapezoid
// (first-order, tau), BUSY falls when the carriage is within 0.01 mm.
TEST(ProfileFitAttacked, ServoLag) {
  std::mt19937 rng(47);
  std::uniform_real_distribution<double> unit(0, 1);
  for (double tau : {0.003, 0.005, 0.010}) {
    for (int axes : {1, 8}) {
      Tally t;
      fresh_attack_tracker();
      for (int i = 0; i < 50 / kFew; ++i) {
        const TimePoint t0 = TimePoint{} + std::chrono::seconds(10);
        const auto p = plan_at(t0 + msecs(20), 50, 250, 100, 1000);
        const double dt = 1e-4;
        auto table = std::make_shared<std::vector<double>>();
        double x = 50;
        TimePoint fall = p.end_time();
        for (int k = 0;; ++k) {
          const TimePoint tk = p.start_time() + to_duration(FractionalSeconds(k * dt));
          table->push_back(x);
          x += (p.position(tk) - x) * dt / tau;
          if (tk > p.end_time() && std::abs(x - 250) < 0.01) {
            fall = tk;
            break;
          }
        }
        const TimePoint s0 = p.start_time();
        auto pos = [table, s0, dt](TimePoint t) {
          const double k = to_seconds(t - s0) / dt;
          if (k <= 0) return 50.0;
          if (k >= double(table->size() - 1)) return 250.0;
          return (*table)[std::size_t(k)];
        };
        Truth tr{pos, s0, fall, 50, 250};
        t.add(poll_truth(attack_tracker(), tr, t0, {100, 1000, 1000}, 25.0 * axes,
                         25.0 * axes * unit(rng)));
      }
      EXPECT_EQ(t.outside, 0) << "tau " << tau * 1e3 << " ms, " << axes << " axes: " << t.str();
    }
  }
}
}  // namespace profile_fit_test
}  // namespace lec6::serve::history
