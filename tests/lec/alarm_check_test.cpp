// ALARM never decided from X4F alone (issue 33, lec/alarm_check.hpp): X4F
// against the alarm code in group 0 and against BUSY, for both polarities.

#include "lec6/lec/alarm_check.hpp"

#include <gtest/gtest.h>

namespace lec6::lec {
namespace {

StatusFlags wire(bool x4f, bool busy = false) {
  StatusFlags f;
  f.set(StatusFlags::Svre, true);
  f.set(StatusFlags::Seton, true);
  f.set(StatusFlags::Alarm, x4f);
  f.set(StatusFlags::Busy, busy);
  return f;
}

AlarmGroup group(uint8_t code) {
  AlarmGroup g;
  g.codes[0] = code;
  return g;
}

TEST(AlarmCheck, PolarityNamesRoundTrip) {
  EXPECT_EQ(parse_alarm_polarity("active-low"), AlarmPolarity::ActiveLow);
  EXPECT_EQ(parse_alarm_polarity("active-high"), AlarmPolarity::ActiveHigh);
  EXPECT_FALSE(parse_alarm_polarity("low"));
  EXPECT_EQ(to_string(AlarmPolarity::ActiveLow), "active-low");
}

TEST(AlarmCheck, NormaliseFlipsOnlyX4F) {
  const StatusFlags w = wire(true);
  const StatusFlags n = normalise_alarm(w, AlarmPolarity::ActiveLow);
  EXPECT_FALSE(n.alarm());
  EXPECT_EQ(n.bits | (1U << StatusFlags::Alarm), w.bits);
  EXPECT_EQ(normalise_alarm(w, AlarmPolarity::ActiveHigh), w);
}

TEST(AlarmCheck, AgreeingAlarmHasItsCodes) {
  const auto j = judge_alarm(wire(true), group(99), AlarmPolarity::ActiveHigh);
  EXPECT_TRUE(j.active);
  EXPECT_EQ(j.codes, std::vector<uint8_t>{99});
  EXPECT_TRUE(j.disagreement.empty());
}

TEST(AlarmCheck, NoX4FAndAnOldCodeIsNoAlarm) {
  const auto j = judge_alarm(wire(false), group(99), AlarmPolarity::ActiveHigh);
  EXPECT_FALSE(j.active);
  EXPECT_TRUE(j.disagreement.empty());
}

// A healthy controller that reports X4F inverted: X4F = 1, no code ever.
TEST(AlarmCheck, X4FWithoutACodeSaysTheControllerIsInverted) {
  const auto j = judge_alarm(wire(true), AlarmGroup{}, AlarmPolarity::ActiveHigh);
  EXPECT_FALSE(j.active);
  EXPECT_EQ(j.suggested, AlarmPolarity::ActiveLow);
  EXPECT_NE(j.disagreement.find("this controller reports ALARM inverted; set `alarm_polarity: "
                                "active-low`"),
            std::string::npos)
      << j.disagreement;
}

// Configured active-low on a controller that is active-high, with a cleared
// alarm in its history: X4F = 0 on the wire reads as an alarm, and BUSY says not.
TEST(AlarmCheck, AlarmWhileBusyIsADisagreementButStillAStop) {
  const StatusFlags n = normalise_alarm(wire(false, true), AlarmPolarity::ActiveLow);
  const auto j = judge_alarm(n, group(62), AlarmPolarity::ActiveLow);
  EXPECT_TRUE(j.active);
  EXPECT_EQ(j.suggested, AlarmPolarity::ActiveHigh);
  EXPECT_NE(j.disagreement.find("BUSY = 1"), std::string::npos) << j.disagreement;
  EXPECT_NE(j.disagreement.find("X4F = 0"), std::string::npos) << j.disagreement;
}

// After a RESET: a code RESET clears that stays is its cause still there, or
// an old code on a healthy controller of the other polarity; both are said,
// with the setting. A code RESET does not clear needs the power cycled.
TEST(AlarmCheck, AResettableCodeLeftAfterResetNamesTheOtherPolarity) {
  const std::string high = alarm_after_reset({62}, AlarmPolarity::ActiveHigh);
  EXPECT_NE(high.find("alarm still active after RESET: 62 ("), std::string::npos) << high;
  EXPECT_NE(high.find("its cause is still there"), std::string::npos) << high;
  EXPECT_NE(high.find("reports ALARM inverted"), std::string::npos) << high;
  EXPECT_NE(high.find("set `alarm_polarity: active-low`"), std::string::npos) << high;
  const std::string low = alarm_after_reset({62, 99}, AlarmPolarity::ActiveLow);
  EXPECT_NE(low.find("62 ("), std::string::npos) << low;
  EXPECT_NE(low.find(", 99 ("), std::string::npos) << low;
  EXPECT_NE(low.find("RESET clears these codes"), std::string::npos) << low;
  EXPECT_NE(low.find("set `alarm_polarity: active-high`"), std::string::npos) << low;
}

// A code RESET does not clear: the power cycle first (alarm_clear_hint's
// words, as every front end gives them); an old code of a healthy inverted
// controller survives that too, so the setting is named after it.
TEST(AlarmCheck, ACodeResetDoesNotClearNeedsThePowerThenNamesThePolarity) {
  const std::string m = alarm_after_reset({62, 149}, AlarmPolarity::ActiveHigh);
  EXPECT_NE(m.find("RESET does not clear alarm 149 (only 48-99): switch the controller's power "
                   "off and on. If ALARM is still on after that"),
            std::string::npos)
      << m;
  EXPECT_NE(m.find("set `alarm_polarity: active-low`"), std::string::npos) << m;
  EXPECT_EQ(m.find("turn the servo off"), std::string::npos) << m;
}

}  // namespace
}  // namespace lec6::lec
