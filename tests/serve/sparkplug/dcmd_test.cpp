// DCMD metric writes to commands (src/serve/sparkplug/dcmd.hpp): the one stop
// rule, one action per DCMD, and nothing half-applied.

#include "sparkplug/dcmd.hpp"

#include <gtest/gtest.h>

namespace lec6::serve::sparkplug {
namespace {

std::size_t index(std::string_view name) {
  const auto m = command_metrics();
  for (std::size_t i = 0; i < m.size(); ++i) {
    if (m[i].name == name) return i;
  }
  ADD_FAILURE() << name;
  return 0;
}

Write w(std::string_view name, Value v) {
  return {index(name), std::move(v)};
}

TEST(SparkplugDcmd, StopRunsAloneWhateverElseTheDcmdHolds) {
  const auto p = plan(
      {w("Command/Move/Position mm", 99999.0), w("Command/Stop", true), w("Command/Home", true)},
      {});
  ASSERT_TRUE(p) << p.error();
  ASSERT_TRUE(p->command);
  EXPECT_EQ(p->command->op, Op::Stop);
  EXPECT_FALSE(p->move.position_mm.has_value());  // the rest is not applied
  EXPECT_NE(p->note.find("only the stop ran"), std::string::npos);
}

TEST(SparkplugDcmd, MoveWithTheSettingsOfThisAndEarlierDcmds) {
  MoveSettings before;
  before.speed_mm_s = 200;
  const auto p =
      plan({w("Command/Move/Position mm", 150.5), w("Command/Move/Execute", true)}, before);
  ASSERT_TRUE(p) << p.error();
  ASSERT_TRUE(p->command);
  EXPECT_EQ(p->command->op, Op::Move);
  EXPECT_EQ(p->command->move.position_001mm, 15050);
  EXPECT_EQ(p->command->move.speed_mm_s, 200);
  EXPECT_EQ(p->move.position_mm, 150.5);
}

TEST(SparkplugDcmd, RefusedWholeNeverHalfApplied) {
  const MoveSettings none;
  auto refused = [&](std::vector<Write> writes, std::string_view why) {
    const auto p = plan(writes, none);
    ASSERT_FALSE(p);
    EXPECT_NE(p.error().find(why), std::string::npos) << p.error();
  };
  refused({w("Command/Move/Execute", true)}, "needs Command/Move/Position mm");
  refused({w("Command/Home", true), w("Command/Reset", true)}, "one action per DCMD");
  refused({w("Command/Move/Speed mm/s", int64_t{70000})}, "speed");
  refused({w("Command/Move/Position mm", 10.0), w("Command/Move/Speed mm/s", int64_t{70000}),
           w("Command/Move/Execute", true)},
          "speed");
  refused({w("Command/Run Step", int64_t{64})}, "0 to 63");
}

TEST(SparkplugDcmd, SettingsAloneAreKept) {
  const auto p = plan({w("Command/Move/Speed mm/s", int64_t{100})}, {});
  ASSERT_TRUE(p) << p.error();
  EXPECT_FALSE(p->command);
  EXPECT_EQ(p->move.speed_mm_s, 100);
}

TEST(SparkplugDcmd, ActionsAsTheApiTakesThem) {
  auto op = [](std::vector<Write> writes) {
    const auto p = plan(writes, {});
    EXPECT_TRUE(p && p->command);
    return p && p->command ? std::optional<Command>(*p->command) : std::nullopt;
  };
  EXPECT_EQ(op({w("Command/Hold", true)})->op, Op::Hold);
  EXPECT_TRUE(op({w("Command/Hold", true)})->on);
  EXPECT_FALSE(op({w("Command/Servo", false)})->on);
  EXPECT_EQ(op({w("Command/Reset", true)})->op, Op::Reset);
  EXPECT_EQ(op({w("Command/Home", true)})->op, Op::Home);
  EXPECT_EQ(op({w("Command/Serial", true)})->op, Op::Serial);
  EXPECT_EQ(op({w("Command/Run Step", int64_t{5})})->step, 5u);
}

}  // namespace
}  // namespace lec6::serve::sparkplug
