// The drift detector (sans-I/O): wear is caught soon after it crosses the
// threshold, a healthy noisy mix never warns, a step-table edit starts a new
// baseline, and a warning clears when the axis comes back.

#include "serve/history/drift.hpp"

#include <gtest/gtest.h>

#include <random>

namespace lec6::serve::history {
namespace {

// A modelled repeated move: duration, peak thrust and settle time with
// Gaussian noise, scaled by `wear` (0.10: +10 %).
struct MoveModel {
  std::string kind = "move";
  std::optional<int> step;
  double start_mm = 10, target_mm = 150, speed = 100;
  double duration_s = 1.5, thrust_pct = 40, settle_s = 0.08;
  double noise = 0.02;  // relative, one sigma

  MotionRecord make(int64_t id, double wear, std::mt19937& rng) const {
    std::normal_distribution<double> n(0, noise);
    MotionRecord r;
    r.id = id;
    r.start_ms = 1'700'000'000'000 + id * 2000;
    r.axis = "x";
    r.kind = kind;
    r.step = step;
    r.outcome = "reached";
    r.start_mm = start_mm + n(rng) * 0.5;  // within the grouping tolerance
    r.target_mm = target_mm;
    if (!step) r.speed_mm_s = speed;
    r.duration_s = duration_s * (1 + wear) * (1 + n(rng));
    r.peak_thrust_pct = thrust_pct * (1 + wear) * (1 + n(rng));
    // Settle times are poll-quantised (20 ms).
    r.settle_s = std::round(settle_s * (1 + n(rng) * 2) / 0.02) * 0.02;
    return r;
  }
};

TEST(Drift, WearOfTenPercentOverThreeHundredMovesWarnsWithinFiftyMovesOfCrossing) {
  DriftDetector d;
  MoveModel m;
  std::mt19937 rng(7);
  const int crossing = 300;  // the wear passes +10 % after move 300
  int warned = -1;
  std::vector<DriftEvent> raised;
  for (int i = 0; i < 600 && warned < 0; ++i) {
    const double wear = 0.10 * i / 300.0;  // +10 % at move 300, and on
    for (const auto& e : d.add(m.make(i + 1, wear, rng))) {
      if (e.raised) {
        raised.push_back(e);
        if (warned < 0) warned = i;
      }
    }
  }
  ASSERT_GE(warned, 0) << "no warning in 600 moves";
  EXPECT_GE(warned, crossing - 30) << "warned long before the threshold: a false alarm";
  EXPECT_LE(warned, crossing + 50) << "crossed at move " << crossing << ", warned at " << warned;
  const DriftWarning& w = raised.front().warning;
  EXPECT_EQ(w.axis, "x");
  EXPECT_NE(w.group.find("move to 150.00 mm"), std::string::npos) << w.group;
  EXPECT_GT(w.drift_pct, 10);
  EXPECT_EQ(w.moves.size(), d.config().window);
  EXPECT_LE(w.since_ms, w.raised_ms);
  EXPECT_FALSE(d.warnings("x").empty());
}

TEST(Drift, TenThousandHealthyMovesOfSeveralGroupsWithNoiseNeverWarn) {
  DriftDetector d;
  std::vector<MoveModel> models(4);
  models[1].target_mm = 300;
  models[1].duration_s = 2.8;
  models[2].kind = "run-step";
  models[2].step = 3;
  models[2].start_mm = 300;
  models[2].target_mm = 10;
  models[2].thrust_pct = 25;
  models[3].kind = "home";
  models[3].target_mm = 0;
  models[3].start_mm = 10;
  models[3].duration_s = 0.9;
  models[3].settle_s = 0.02;
  for (auto& m : models) m.noise = 0.03;
  std::mt19937 rng(42);
  std::uniform_int_distribution<std::size_t> pick(0, models.size() - 1);
  int warnings = 0;
  for (int i = 0; i < 10'000; ++i) {
    for (const auto& e : d.add(models[pick(rng)].make(i + 1, 0, rng))) {
      if (e.raised) {
        ++warnings;
        ADD_FAILURE() << "move " << i << ": " << metric_name(e.warning.metric) << " of "
                      << e.warning.group << " +" << e.warning.drift_pct << " %";
      }
    }
  }
  EXPECT_EQ(warnings, 0);
  EXPECT_EQ(d.groups("x").size(), 4u);
}

TEST(Drift, AStepChangeRightAfterAStepTableEditStartsANewBaselineAndDoesNotWarn) {
  DriftDetector d;
  MoveModel m;
  m.kind = "run-step";
  m.step = 2;
  std::mt19937 rng(3);
  int64_t id = 1;
  for (int i = 0; i < 100; ++i) d.add(m.make(id++, 0, rng));
  d.settings_changed("x", 2);  // e.g. a slower speed in step 2: +40 %
  for (int i = 0; i < 200; ++i) {
    for (const auto& e : d.add(m.make(id++, 0.40, rng))) {
      ADD_FAILURE() << "warned after a step-table edit: " << e.warning.group;
    }
  }
  // Without the edit, the same step change warns.
  DriftDetector fresh;
  for (int i = 0; i < 100; ++i) fresh.add(m.make(id++, 0, rng));
  int raised = 0;
  for (int i = 0; i < 30; ++i) {
    for (const auto& e : fresh.add(m.make(id++, 0.40, rng))) raised += e.raised;
  }
  EXPECT_GE(raised, 1);
}

TEST(Drift, AWarningClearsWhenTheAxisComesBackWithHysteresis) {
  DriftDetector d;
  MoveModel m;
  std::mt19937 rng(11);
  int64_t id = 1;
  for (int i = 0; i < 60; ++i) d.add(m.make(id++, 0, rng));
  int raised = 0, cleared = 0;
  for (int i = 0; i < 40; ++i) {
    for (const auto& e : d.add(m.make(id++, 0.20, rng))) (e.raised ? raised : cleared)++;
  }
  EXPECT_EQ(raised, 2) << "duration and peak thrust";
  // Back to +7 %: above the clearing level (+5 %), so it stays.
  for (int i = 0; i < 40; ++i) {
    for (const auto& e : d.add(m.make(id++, 0.07, rng))) (e.raised ? raised : cleared)++;
  }
  EXPECT_EQ(cleared, 0);
  EXPECT_EQ(d.warnings("x").size(), 2u);
  // Lubricated: back to normal, the warnings clear.
  for (int i = 0; i < 40; ++i) {
    for (const auto& e : d.add(m.make(id++, 0, rng))) (e.raised ? raised : cleared)++;
  }
  EXPECT_EQ(cleared, 2);
  EXPECT_EQ(raised, 2);
  EXPECT_TRUE(d.warnings("x").empty());
}

TEST(Drift, FailedMovesAndJogsAreNotCompared) {
  DriftDetector d;
  MoveModel m;
  std::mt19937 rng(5);
  for (int i = 0; i < 60; ++i) d.add(m.make(i + 1, 0, rng));
  for (int i = 60; i < 120; ++i) {
    auto r = m.make(i + 1, 1.0, rng);
    r.outcome = "stopped";
    EXPECT_TRUE(d.add(r).empty());
    r.outcome = "reached";
    r.kind = "jog";
    EXPECT_TRUE(d.add(r).empty());
  }
  EXPECT_TRUE(d.warnings("x").empty());
}

}  // namespace
}  // namespace lec6::serve::history
