// Commands as HTTP and MQTT take them: every value checked before anything
// reaches the line, errors naming the field.

#include "ops/commands.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace lec6::serve {
namespace {

using nlohmann::json;
using ::testing::HasSubstr;

CommandError error_of(std::string_view op, const json& args) {
  auto c = parse_command(op, args);
  EXPECT_FALSE(c) << op << " " << args.dump();
  return c ? CommandError{} : c.error();
}

TEST(Commands, AMoveInTheManualsUnits) {
  auto c = parse_command(
      "move",
      json{{"position_mm", 150.25}, {"speed_mm_s", 500}, {"push_pct", 50}, {"trigger_pct", 40}});
  ASSERT_TRUE(c);
  EXPECT_EQ(c->op, Op::Move);
  EXPECT_EQ(c->move.position_001mm, 15025);
  EXPECT_EQ(c->move.speed_mm_s, 500);
  EXPECT_EQ(c->move.pushing_force_pct, 50);
  auto step = parse_command("move", json{{"step", 3}});
  ASSERT_TRUE(step);
  EXPECT_EQ(step->op, Op::RunStep);
  EXPECT_EQ(step->step, 3u);
}

// Issue 24: real controllers accept in position 0, so the HTTP API and MQTT
// (both parse_command) do too; below 0 is refused, naming the field.
TEST(Commands, InPositionZeroIsAccepted) {
  auto c =
      parse_command("move", json{{"position_mm", 50}, {"speed_mm_s", 16}, {"in_position_mm", 0}});
  ASSERT_TRUE(c) << c.error().message;
  EXPECT_EQ(c->move.in_position_001mm, 0);
  EXPECT_EQ(error_of("move", json{{"position_mm", 50}, {"in_position_mm", -0.01}}).field,
            "in_position_mm");
}

TEST(Commands, BadValuesNameTheField) {
  auto e = error_of("move", json{{"position_mm", 150}, {"speed_mm_s", 70000}});
  EXPECT_EQ(e.field, "speed_mm_s");
  EXPECT_THAT(e.message, HasSubstr("65535"));
  EXPECT_EQ(error_of("move", json{{"speed_mm_s", 100}}).field, "position_mm");
  EXPECT_EQ(error_of("move", json{{"position_mm", 1.234}}).field, "position_mm");
  EXPECT_EQ(error_of("move", json{{"position_mm", "far"}}).field, "position_mm");
  EXPECT_EQ(error_of("move", json{{"position_mm", 1}, {"speeed_mm_s", 3}}).field, "speeed_mm_s");
  EXPECT_EQ(error_of("move", json{{"position_mm", 1}, {"trigger_pct", 3}}).field, "trigger_pct");
  EXPECT_EQ(error_of("servo", json::object()).field, "on");
  EXPECT_EQ(error_of("servo", json{{"on", "yes"}}).field, "on");
  EXPECT_EQ(error_of("jog", json{{"direction", "up"}, {"lease_ms", 500}}).field, "direction");
  EXPECT_EQ(error_of("jog", json{{"direction", "+"}}).field, "lease_ms");
  EXPECT_EQ(error_of("move", json{{"step", 64}}).field, "step");
  EXPECT_EQ(error_of("fly", json::object()).field, "op");
  EXPECT_EQ(error_of("move", json::array()).field, "");
}

TEST(Commands, StepWriteTakesCsvAndCliNames) {
  auto c =
      parse_command("step-write", json{{"step", 3}, {"speed_mm_s", 250}, {"position", "120.50"}});
  ASSERT_TRUE(c);
  EXPECT_EQ(c->fields.at(lec::StepField::Speed), 250);
  EXPECT_EQ(c->fields.at(lec::StepField::Position), 12050);
  EXPECT_EQ(error_of("step-write", json{{"step", 3}, {"speed_mm_s", 0}}).field, "speed_mm_s");
  EXPECT_EQ(error_of("step-write", json{{"step", 3}, {"colour", 1}}).field, "colour");
  EXPECT_EQ(error_of("step-write", json{{"step", 3}}).field, "");
}

TEST(Commands, MqttEnvelopeKeysAreNotArguments) {
  EXPECT_TRUE(parse_command("stop", json{{"id", "a1"}, {"op", "stop"}, {"valid_for", 5}}));
}

}  // namespace
}  // namespace lec6::serve
