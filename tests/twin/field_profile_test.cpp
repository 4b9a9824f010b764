// Field profiles: YAML/JSON → the twin's configs, and every error naming the
// file, the line and the rule.

#include "lec6/twin/field_profile.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <string>

namespace lec6::twin {
namespace {

using ::testing::HasSubstr;

const char* kYaml = R"(name: quirky
description: a test profile
actuator:
  busy_delay_ms: 15
  busy_min_ms: 60
  target_update_late: true
  workpiece_mm: 350
line:
  baud: 115200
  timing: fast
  noise_rate: 2.5
faults:
  seed: 42
  drop_rate: 0.01
)";

TEST(FieldProfile, EveryKeyLandsInItsConfig) {
  const FieldProfile p = parse_field_profile(kYaml, "p.yaml");
  EXPECT_EQ(p.name, "quirky");
  EXPECT_EQ(p.description, "a test profile");
  EXPECT_EQ(p.actuator.busy_delay, std::chrono::milliseconds(15));
  EXPECT_EQ(p.actuator.busy_min, std::chrono::milliseconds(60));
  EXPECT_TRUE(p.actuator.target_update_late);
  EXPECT_EQ(p.actuator.workpiece_mm, 350.0);
  EXPECT_EQ(p.line.line.baud, 115200u);
  EXPECT_EQ(p.line.timing, sim::Timing::Fast);
  EXPECT_EQ(p.faults.noise_rate, 2.5);
  EXPECT_EQ(p.faults.seed, 42u);
  EXPECT_EQ(p.faults.drop, 0.01);
  EXPECT_EQ(p.actuator.stroke_max_mm, sim::ActuatorConfig{}.stroke_max_mm) << "untouched";
  EXPECT_TRUE(p.given.count("actuator.busy_delay_ms"));
  EXPECT_FALSE(p.given.count("actuator.stroke_max_mm"));
}

TEST(FieldProfile, JsonIsYamlToo) {
  const FieldProfile p = parse_field_profile(
      R"({"name": "j", "actuator": {"busy_min_ms": 60}, "line": {"noise_rate": 1}})", "p.json");
  EXPECT_EQ(p.actuator.busy_min, std::chrono::milliseconds(60));
  EXPECT_EQ(p.faults.noise_rate, 1.0);
}

TEST(FieldProfile, TheShippedProfileCombinesEveryQuirk) {
  const FieldProfile p =
      load_field_profile(std::string(LEC6_TEST_DATA_DIR) + "/../../profiles/field-quirks.yaml");
  EXPECT_EQ(p.name, "field-quirks");
  EXPECT_GT(p.actuator.busy_delay, Duration::zero());
  EXPECT_GT(p.actuator.busy_min, Duration::zero());
  EXPECT_TRUE(p.actuator.target_update_late);
  EXPECT_GT(p.faults.noise_rate, 0.0);
  // Within what the client's start window (200 ms) is made for.
  EXPECT_LT(p.actuator.busy_delay + p.actuator.busy_min, std::chrono::milliseconds(200));
}

TEST(FieldProfile, AnEmptyProfileChangesNothingAndTheFileNamesIt) {
  const FieldProfile p = parse_field_profile("", "empty.yaml");
  EXPECT_EQ(p.actuator.busy_delay, Duration::zero());
  EXPECT_TRUE(p.given.empty());
}

std::string error_of(const std::string& text) {
  try {
    parse_field_profile(text, "bad.yaml");
  } catch (const ProfileError& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(FieldProfile, ErrorsNameFileLineAndRule) {
  EXPECT_EQ(error_of("actuator:\n  busy_delay_ms: -5\n"),
            "bad.yaml:2: actuator.busy_delay_ms: -5 is outside 0 to 10000 ms");
  EXPECT_THAT(error_of("actuator:\n  busy_dely_ms: 5\n"),
              HasSubstr("bad.yaml:2: actuator.busy_dely_ms: unknown key (known here: "));
  EXPECT_THAT(error_of("actuator:\n  busy_dely_ms: 5\n"), HasSubstr("busy_delay_ms"));
  EXPECT_EQ(error_of("line:\n  noise_rate: lots\n"),
            "bad.yaml:2: line.noise_rate: 'lots' is not a number bytes/s");
  EXPECT_EQ(error_of("line:\n  timing: slow\n"),
            "bad.yaml:2: line.timing: 'slow' is not real or fast");
  EXPECT_THAT(error_of("line:\n  baud: 12345\n"),
              HasSubstr("bad.yaml:2: line.baud: 12345 is not a baud rate"));
  EXPECT_EQ(error_of("actuator:\n  target_update_late: maybe\n"),
            "bad.yaml:2: actuator.target_update_late: 'maybe' is not true or false");
  EXPECT_THAT(error_of("speed: 3\n"), HasSubstr("bad.yaml:1: speed: unknown key"));
  EXPECT_THAT(error_of("actuator: [1, 2]\n"), HasSubstr("bad.yaml:1: actuator: expected a map"));
  EXPECT_THAT(error_of("actuator:\n  busy_min_ms: [1\n"), HasSubstr("bad.yaml:"));
  EXPECT_THAT(error_of("actuator:\n  initial_position_mm: 500\n"),
              HasSubstr("bad.yaml: actuator: initial position 500 mm is outside the stroke"));
  try {
    load_field_profile("/nonexistent/x.yaml");
    FAIL();
  } catch (const ProfileError& e) {
    EXPECT_THAT(e.what(), HasSubstr("/nonexistent/x.yaml: cannot read"));
  }
}

}  // namespace
}  // namespace lec6::twin
