// The history: section of lec serve's config, and the twin's wear setting:
// defaults, every key, and mistakes named by file, line and key.

#include <gtest/gtest.h>

#include <gmock/gmock.h>

#include "lec6/serve/config.hpp"

namespace lec6::serve {
namespace {

using ::testing::HasSubstr;

const char* kLines =
    "lines:\n  - port: sim\n    sim: {wear_pct_per_m: 0.25}\n    axes: [{id: 1}]\n";

std::string error_of(const std::string& text) {
  try {
    parse_config(text, "lec6.yaml");
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "(accepted)";
}

TEST(HistoryConfig, OffWithoutTheSectionAndEveryKeyWhenGiven) {
  auto c = parse_config(kLines, "lec6.yaml");
  EXPECT_FALSE(c.history);  // `lec serve` then keeps it in the default directory
  EXPECT_FALSE(c.history_off);
  EXPECT_DOUBLE_EQ(c.lines[0].sim.wear_pct_per_m, 0.25);
  c = parse_config(std::string(kLines) + R"(history:
  state_dir: /var/lib/lec6
  max_age_days: 30
  max_size_mb: 5
  queue: 100
  drift_threshold_pct: 15
  drift_baseline_moves: 10
  drift_tolerance_mm: 1
  services:
    - {what: lubricate, every_km: 2000}
    - {what: belt, every_moves: 1000000}
)",
                   "lec6.yaml");
  ASSERT_TRUE(c.history);
  EXPECT_EQ(c.history->state_dir, "/var/lib/lec6");
  EXPECT_DOUBLE_EQ(c.history->max_age_days, 30);
  EXPECT_DOUBLE_EQ(c.history->max_size_mb, 5);
  EXPECT_EQ(c.history->queue, 100u);
  EXPECT_DOUBLE_EQ(c.history->drift_threshold_pct, 15);
  EXPECT_EQ(c.history->drift_baseline_moves, 10u);
  ASSERT_EQ(c.history->services.size(), 2u);
  EXPECT_EQ(c.history->services[0].what, "lubricate");
  EXPECT_EQ(c.history->services[0].every_km, 2000);
  EXPECT_EQ(c.history->services[1].every_moves, 1e6);
  c = parse_config(std::string(kLines) + "history: {state_dir: s}\n", "lec6.yaml");
  EXPECT_DOUBLE_EQ(c.history->max_size_mb, 100);
  EXPECT_DOUBLE_EQ(c.history->drift_threshold_pct, 10);
  // Issue 32: without state_dir, the default directory; `false` turns it off.
  c = parse_config(std::string(kLines) + "history: {max_size_mb: 5}\n", "lec6.yaml");
  ASSERT_TRUE(c.history);
  EXPECT_TRUE(c.history->state_dir.empty());
  c = parse_config(std::string(kLines) + "history: true\n", "lec6.yaml");
  ASSERT_TRUE(c.history);
  EXPECT_TRUE(c.history->state_dir.empty());
  c = parse_config(std::string(kLines) + "history: false\n", "lec6.yaml");
  EXPECT_FALSE(c.history);
  EXPECT_TRUE(c.history_off);
}

TEST(HistoryConfig, MistakesNameTheKey) {
  const std::string base(kLines);
  EXPECT_THAT(error_of(base + "history: {state_dir: ''}\n"), HasSubstr("history.state_dir"));
  EXPECT_THAT(error_of(base + "history: [1]\n"), HasSubstr("history"));
  EXPECT_THAT(error_of(base + "history: {state_dir: s, max_size_mb: -1}\n"),
              HasSubstr("history.max_size_mb"));
  EXPECT_THAT(error_of(base + "history: {state_dir: s, colour: red}\n"), HasSubstr("colour"));
  EXPECT_THAT(error_of(base + "history: {state_dir: s, services: [{what: x}]}\n"),
              HasSubstr("exactly one of every_km"));
  EXPECT_THAT(error_of(base + "history: {state_dir: s, services: [{every_km: 1}]}\n"),
              HasSubstr("history.services[0].what"));
  EXPECT_THAT(
      error_of("lines:\n  - port: sim\n    sim: {wear_pct_per_m: -2}\n    axes: [{id: 1}]\n"),
      HasSubstr("lines[0].sim.wear_pct_per_m"));
  EXPECT_THAT(error_of(base + "history: {state_dir: s, queue: 3}\n"), HasSubstr("lec6.yaml:"));
}

}  // namespace
}  // namespace lec6::serve
