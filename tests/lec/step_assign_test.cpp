#include "lec6/lec/step_assign.hpp"
#include "lec6/lec/step_defaults.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace lec6::lec {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;

using Args = std::vector<std::string>;

const StepData kFull{MovementMode::Absolute, 500, 15000, 5000, 5000, 0, 0, 20, 100, 0, 0, 100};

std::string joined(const AssignErrors& errors) {
  std::string out;
  for (const auto& e : errors) out += e + "\n";
  return out;
}

TEST(StepAssign, ParsesNamesCaseInsensitivelyIncludingLongNames) {
  auto a = parse_assignments(Args{"Speed=600", "pushing_speed=30", "IN_POSITION_MM=0.5",
                                  "position=-12.5", "mode=inc", "inp=2"});
  ASSERT_FALSE(a) << "in-position given twice (IN_POSITION_MM and inp)";
  a = parse_assignments(
      Args{"Speed=600", "pushing_speed=30", "IN_POSITION_MM=0.5", "position=-12.5", "mode=inc"});
  ASSERT_TRUE(a) << joined(a.error());
  EXPECT_THAT(*a, ElementsAre(StepAssignment{StepField::Speed, 600},
                              StepAssignment{StepField::PushingSpeed, 30},
                              StepAssignment{StepField::InPosition, 50},
                              StepAssignment{StepField::Position, -1250},
                              StepAssignment{StepField::MovementMode, 2}));
}

TEST(StepAssign, BlankBaseTakesTheDefaultsAndNamesThem) {
  // One set of defaults everywhere (issue 27): a blank step starts from them.
  auto r = assign_step(5, StepData{}, Args{"speed=500", "position=150"});
  ASSERT_TRUE(r) << r.error().front();
  auto want = default_step_data();
  want.speed_mm_s = 500;
  want.position_001mm = 15000;
  EXPECT_EQ(r->step.to_registers(), want.to_registers());
  EXPECT_TRUE(validate(r->step).empty());
  EXPECT_THAT(r->defaulted,
              ElementsAre(StepField::MovementMode, StepField::Acceleration,
                          StepField::Deceleration, StepField::PushingSpeed,
                          StepField::MovingForce, StepField::InPosition));
  EXPECT_TRUE(r->warnings.empty());
  // A step that is not blank keeps its own values: nothing is defaulted.
  auto again = assign_step(5, r->step, Args{"speed=400"});
  ASSERT_TRUE(again);
  EXPECT_TRUE(again->defaulted.empty());
  EXPECT_EQ(again->step.acceleration_mm_s2, 1000);
}

TEST(StepAssign, AZeroMovingForceIsWrittenWithAWarning) {
  auto r = assign_step(5, StepData{}, Args{"position=10", "moving-force=0"});
  ASSERT_TRUE(r);
  EXPECT_THAT(r->warnings, ElementsAre(HasSubstr("moving force is 0 %")));
}

TEST(StepAssign, FullSetOnABlankStepIsAccepted) {
  auto r = assign_step(5, StepData{},
                       Args{"mode=abs", "speed=500", "position=150", "accel=5000", "decel=5000",
                            "push-speed=20", "moving-force=100", "in-position=1"});
  ASSERT_TRUE(r) << joined(r.error());
  EXPECT_EQ(r->step, kFull);
  EXPECT_THAT(r->changed,
              ElementsAre(StepField::MovementMode, StepField::Speed, StepField::Position,
                          StepField::Acceleration, StepField::Deceleration, StepField::PushingSpeed,
                          StepField::MovingForce, StepField::InPosition));
}

TEST(StepAssign, ChangesOneFieldOfAnExistingStep) {
  auto r = assign_step(2, kFull, Args{"speed=600"});
  ASSERT_TRUE(r) << joined(r.error());
  StepData want = kFull;
  want.speed_mm_s = 600;
  EXPECT_EQ(r->step.to_registers(), want.to_registers());
  EXPECT_THAT(r->changed, ElementsAre(StepField::Speed));

  auto same = assign_step(2, kFull, Args{"speed=500"});
  ASSERT_TRUE(same);
  EXPECT_TRUE(same->changed.empty());
}

TEST(StepAssign, FromAnotherStepStartsFromItsRecord) {
  StepData source = kFull;
  source.position_001mm = -2000;
  source.pushing_force_pct = 60;
  source.trigger_level_pct = 50;
  // Step 5 is blank; copy step 3 and change the speed.
  auto r = assign_step(5, StepData{}, Args{"speed=100"}, CopySource{3, source});
  ASSERT_TRUE(r) << joined(r.error());
  StepData want = source;
  want.speed_mm_s = 100;
  EXPECT_EQ(r->step.to_registers(), want.to_registers());
  EXPECT_EQ(r->changed.size(), 10u);  // all but area1 and area2, relative to blank step 5

  // Against a non-blank step 5, changed is relative to step 5's record.
  auto r2 = assign_step(5, kFull, Args{}, CopySource{3, source});
  ASSERT_TRUE(r2) << joined(r2.error());
  EXPECT_EQ(r2->step, source);
  EXPECT_THAT(r2->changed,
              ElementsAre(StepField::Position, StepField::PushingForce, StepField::TriggerLevel));

  auto blank_source = assign_step(5, kFull, Args{"speed=1"}, CopySource{3, StepData{}});
  ASSERT_FALSE(blank_source);
  EXPECT_THAT(blank_source.error(),
              ElementsAre("step 3 is blank: there is nothing to copy with --from 3"));
}

TEST(StepAssign, NothingToSetIsAnError) {
  auto r = assign_step(1, kFull, Args{});
  ASSERT_FALSE(r);
  EXPECT_THAT(r.error()[0], HasSubstr("nothing to set for step 1"));
}

TEST(StepAssign, UnknownFieldSuggestsTheClosestName) {
  auto r = assign_step(1, kFull, Args{"spede=5"});
  ASSERT_FALSE(r);
  EXPECT_THAT(r.error(),
              ElementsAre("unknown field 'spede': did you mean 'speed'? known fields are mode, "
                          "speed, position, accel, decel, push, trigger, push-speed, "
                          "moving-force, area1, area2, in-position"));

  EXPECT_THAT(unknown_field_message("pushing_sped"), HasSubstr("did you mean 'push-speed'?"));
  EXPECT_THAT(unknown_field_message("tigger"), HasSubstr("did you mean 'trigger'?"));
  const std::string far = unknown_field_message("colour");
  EXPECT_EQ(far.find("did you mean"), std::string::npos) << far;
  EXPECT_THAT(far, HasSubstr("unknown field 'colour': known fields are mode, speed"));
}

TEST(StepAssign, OutOfRangeValueNamesFieldAndRange) {
  auto r = assign_step(1, kFull, Args{"speed=70000"});
  ASSERT_FALSE(r);
  EXPECT_THAT(r.error(), ElementsAre("speed 70000 mm/s is out of range: allowed 1 to 65535 mm/s"));

  auto mm = assign_step(1, kFull, Args{"position=1.005"});
  ASSERT_FALSE(mm);
  EXPECT_THAT(mm.error()[0], HasSubstr("more than two decimals"));
}

TEST(StepAssign, DuplicateFieldIsAnError) {
  auto r = assign_step(1, kFull, Args{"speed=100", "Speed_mm_s=100"});
  ASSERT_FALSE(r);
  EXPECT_THAT(r.error(), ElementsAre("speed is given twice ('speed=100' and 'Speed_mm_s=100'): "
                                     "give each field once"));
}

TEST(StepAssign, ResultMustPassCrossFieldRules) {
  StepData pushing = kFull;
  pushing.pushing_force_pct = 50;
  pushing.trigger_level_pct = 30;
  auto r = assign_step(2, pushing, Args{"push=20"});
  ASSERT_FALSE(r);
  EXPECT_THAT(r.error(), ElementsAre("step 2: trigger level 30 % exceeds pushing force 20 %"));

  auto fixed = assign_step(2, pushing, Args{"push=20", "trigger=20"});
  ASSERT_TRUE(fixed) << joined(fixed.error());
  EXPECT_THAT(fixed->changed, ElementsAre(StepField::PushingForce, StepField::TriggerLevel));

  // On a blank step, a broken rule between given fields is reported as such.
  auto blank = assign_step(4, StepData{},
                           Args{"mode=abs", "speed=1", "accel=1", "decel=1", "push-speed=1",
                                "in-position=1", "push=50", "trigger=60"});
  ASSERT_FALSE(blank);
  EXPECT_THAT(blank.error(), ElementsAre("step 4: trigger level 60 % exceeds pushing force 50 %"));
}

TEST(StepAssign, ReportsEveryErrorAndAppliesNothing) {
  auto r = assign_step(1, kFull, Args{"spede=1", "speed=0", "position", "=5", "mode=", "mode=abs"});
  ASSERT_FALSE(r);
  EXPECT_THAT(r.error(), ElementsAre(HasSubstr("unknown field 'spede'"),
                                     "speed 0 mm/s is out of range: allowed 1 to 65535 mm/s",
                                     "'position' is not field=value (e.g. speed=500)",
                                     "'=5' is not field=value (e.g. speed=500)",
                                     "mode: no value after '=' (e.g. mode=...)"));
}

}  // namespace
}  // namespace lec6::lec
