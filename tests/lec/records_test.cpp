#include <gtest/gtest.h>

#include <random>

#include "lec6/lec/alarms.hpp"
#include "lec6/lec/equipment_name.hpp"
#include "lec6/lec/flags.hpp"
#include "lec6/lec/state_data.hpp"
#include "lec6/lec/step_data.hpp"
#include "lec6/lec/units.hpp"

namespace lec6::lec {
namespace {

StepData random_step(std::mt19937& rng) {
  auto i32 = [&] { return static_cast<int32_t>(rng()); };
  auto u16 = [&] { return static_cast<uint16_t>(rng()); };
  StepData s;
  s.movement_mode = static_cast<MovementMode>(u16());
  s.speed_mm_s = u16();
  s.position_001mm = i32();
  s.acceleration_mm_s2 = u16();
  s.deceleration_mm_s2 = u16();
  s.pushing_force_pct = u16();
  s.trigger_level_pct = u16();
  s.pushing_speed_mm_s = u16();
  s.moving_force_pct = u16();
  s.area1_001mm = i32();
  s.area2_001mm = i32();
  s.in_position_001mm = i32();
  return s;
}

TEST(StepData, RoundTripsThroughRegistersForRandomRecords) {
  std::mt19937 rng(2024);
  for (int n = 0; n < 10000; ++n) {
    const StepData s = random_step(rng);
    const auto regs = s.to_registers();
    ASSERT_EQ(StepData::from_registers(regs), s);
    // And field by field through the metadata table.
    StepData rebuilt;
    for (const auto& f : step_fields()) set_field(rebuilt, f.field, get_field(s, f.field));
    ASSERT_EQ(rebuilt, s);
  }
}

TEST(StepData, LayoutMatchesTheManualExample) {
  // Manual §7.3.1: ABS, 500 mm/s, 300.00 mm, 5000, 5000, 0, 0, 20, 100, 0, 0, 1.00.
  StepData d{MovementMode::Absolute, 500, 30000, 5000, 5000, 0, 0, 20, 100, 0, 0, 100};
  const std::array<uint16_t, 16> want{0x0001, 0x01F4, 0x0000, 0x7530, 0x1388, 0x1388, 0, 0,
                                      0x0014, 0x0064, 0,      0,      0,      0,      0, 0x0064};
  EXPECT_EQ(d.to_registers(), want);
  EXPECT_TRUE(validate(d).empty());
}

TEST(StepData, NegativeValuesAreTwosComplementHighWordFirst) {
  StepData s;
  s.position_001mm = -1;
  s.area1_001mm = -15000;
  const auto r = s.to_registers();
  EXPECT_EQ(r[2], 0xFFFF);
  EXPECT_EQ(r[3], 0xFFFF);
  EXPECT_EQ(r[10], 0xFFFF);
  EXPECT_EQ(r[11], static_cast<uint16_t>(-15000 & 0xFFFF));
  EXPECT_EQ(StepData::from_registers(r).area1_001mm, -15000);
}

TEST(Validation, MessagesNameFieldValueAndRange) {
  StepData s{MovementMode::Absolute, 500, 15000, 5000, 5000, 50, 80, 20, 100, 0, 0, 100};
  const auto msgs = validation_messages(s, 3);
  ASSERT_EQ(msgs.size(), 1u);
  EXPECT_EQ(msgs[0], "step 3: trigger level 80 % exceeds pushing force 50 %");

  s.trigger_level_pct = 10;
  s.moving_force_pct = 301;
  s.movement_mode = static_cast<MovementMode>(7);
  const auto more = validate(s);
  ASSERT_EQ(more.size(), 2u);
  EXPECT_EQ(more[0].field, StepField::MovementMode);
  EXPECT_EQ(more[1].message, "moving-force 301 % is out of range (0 to 300 %)");
}

TEST(Validation, ABlankStepNamesEveryMissingField) {
  const auto issues = validate(StepData{});
  std::vector<StepField> fields;
  for (const auto& i : issues) fields.push_back(i.field);
  EXPECT_EQ(fields, (std::vector<StepField>{StepField::MovementMode, StepField::Speed,
                                            StepField::Acceleration, StepField::Deceleration,
                                            StepField::PushingSpeed}));  // in position 0 is valid
  EXPECT_TRUE(StepData{}.is_blank());
}

TEST(StepFields, AcceptShortLongAndCsvNamesCaseInsensitive) {
  EXPECT_EQ(find_step_field("push-speed")->field, StepField::PushingSpeed);
  EXPECT_EQ(find_step_field("PUSHING_SPEED")->field, StepField::PushingSpeed);
  EXPECT_EQ(find_step_field("pushing_speed_mm_s")->field, StepField::PushingSpeed);
  EXPECT_EQ(find_step_field("Trigger_Level")->field, StepField::TriggerLevel);
  EXPECT_EQ(find_step_field("in-position")->field, StepField::InPosition);
  EXPECT_EQ(find_step_field("position_mm")->field, StepField::Position);
  EXPECT_EQ(find_step_field("nonsense"), nullptr);
}

TEST(StepFields, ParseChecksRangesAndUnits) {
  EXPECT_EQ(*parse_field(StepField::Position, "150.00"), 15000);
  EXPECT_EQ(*parse_field(StepField::Position, "-0.5"), -50);
  EXPECT_EQ(*parse_field(StepField::MovementMode, "ABS"), 1);
  EXPECT_EQ(*parse_field(StepField::MovementMode, "inc"), 2);
  auto speed = parse_field(StepField::Speed, "70000");
  ASSERT_FALSE(speed);
  EXPECT_EQ(speed.error(), "speed 70000 mm/s is out of range: allowed 1 to 65535 mm/s");
  auto decimals = parse_field(StepField::Position, "1.234");
  ASSERT_FALSE(decimals);
  EXPECT_NE(decimals.error().find("two decimals"), std::string::npos);
  EXPECT_FALSE(parse_field(StepField::Speed, "12.5"));
  // In position 0 is accepted (field evidence, issue 24); below 0 is not.
  EXPECT_EQ(*parse_field(StepField::InPosition, "0"), 0);
  EXPECT_FALSE(parse_field(StepField::InPosition, "-0.01"));
  EXPECT_EQ(format_field(StepField::Position, 15000), "150.00");
  EXPECT_EQ(format_field(StepField::MovementMode, 2), "inc");
}

TEST(Units, MillimetresRoundTripToHundredths) {
  for (int64_t v : {0L, 1L, -1L, 99L, 100L, -15000L, 2147483647L, -2147483647L}) {
    auto back = parse_mm(format_mm(v));
    ASSERT_TRUE(back) << v;
    EXPECT_EQ(*back, v);
  }
  EXPECT_EQ(format_mm(-5), "-0.05");
  EXPECT_EQ(*parse_mm("150,5"), 15050);  // decimal comma from spreadsheets
  EXPECT_FALSE(parse_mm("21474836.48"));
  EXPECT_FALSE(parse_mm("abc"));
  EXPECT_FALSE(parse_mm(""));
  EXPECT_FALSE(parse_mm("-"));
}

TEST(StateData, RoundTripsAndDecodesPosition) {
  std::mt19937 rng(5);
  for (int n = 0; n < 1000; ++n) {
    StateData s{static_cast<int32_t>(rng()), static_cast<uint16_t>(rng()),
                static_cast<uint16_t>(rng()), static_cast<int32_t>(rng()),
                static_cast<uint16_t>(rng())};
    const auto r = s.to_registers();
    ASSERT_EQ(StateData::from_registers(r), s);
  }
}

TEST(StatusFlags, NamesAndBitsFollowX40ToX4F) {
  StatusFlags f;
  f.set(StatusFlags::Busy, true);
  f.set(StatusFlags::Alarm, true);
  f.set_out(5);
  EXPECT_EQ(f.bits, 0x8105);
  EXPECT_EQ(f.describe(), "BUSY ALARM");
  EXPECT_EQ(f.out(), 5);
  const auto p = f.packed();
  EXPECT_EQ(StatusFlags::from_packed(p), f);
}

TEST(ControlFlags, CoilsMapToBits) {
  ControlFlags c;
  c.set(Coil::IN1, true);
  c.set(Coil::SVON, true);
  c.set(Coil::SerialMode, true);
  EXPECT_EQ(c.selected_step(), 2);
  EXPECT_EQ(c.y10_1f, 0x0202);
  EXPECT_TRUE(c.test(Coil::SerialMode));
  EXPECT_EQ(coil_name(address(Coil::SVON)), "SVON");
}

TEST(AlarmHistory, PushShiftsGroupsAndRoundTrips) {
  AlarmHistory h;
  for (uint8_t code = 1; code <= 20; ++code) h.push(AlarmGroup{{code, 0, 0, 0, 0, 0, 0, 0}});
  EXPECT_EQ(h.groups[0].codes[0], 20);
  EXPECT_EQ(h.groups[15].codes[0], 5);
  const auto regs = h.to_registers();
  EXPECT_EQ(regs[0], 20 << 8);
  EXPECT_EQ(AlarmHistory::from_registers(regs), h);
  EXPECT_TRUE(alarm_resettable(alarm::kNotHomed));
  EXPECT_FALSE(alarm_resettable(alarm::kPositioningTimeout));
  EXPECT_NE(alarm_meaning(alarm::kStepNotRegistered).find("blank"), std::string_view::npos);
}

TEST(EquipmentName, FourteenPrintableCharsNulPadded) {
  auto n = EquipmentName::make("AXIS-1");
  ASSERT_TRUE(n);
  const auto regs = n->to_registers();
  EXPECT_EQ(regs[0], ('A' << 8) | 'X');
  EXPECT_EQ(regs[3], 0);
  EXPECT_EQ(EquipmentName::from_registers(regs), *n);
  EXPECT_FALSE(EquipmentName::make("fifteen chars!!"));
  EXPECT_FALSE(EquipmentName::make("tab\there"));
  EXPECT_TRUE(EquipmentName::make("fourteen chars"));
}

}  // namespace
}  // namespace lec6::lec
