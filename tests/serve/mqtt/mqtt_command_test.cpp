// MQTT commands: the envelope (id, op, valid_for, issued_at) and the
// staleness rules, with the time given, never read.

#include "mqtt/mqtt_command.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "ops/commands.hpp"

namespace lec6::serve {
namespace {

using nlohmann::json;
using ::testing::HasSubstr;

constexpr double kNow = 1767950000.0;

Received at_now(const std::string& payload) {
  return Received{payload, false, std::nullopt, kNow};
}

EnvelopeError envelope_error(const std::string& payload) {
  const auto e = parse_envelope(at_now(payload), 5);
  if (e) ADD_FAILURE() << "accepted: " << payload;
  return e ? EnvelopeError{} : e.error();
}

TEST(MqttEnvelope, ReadsIdOpAndTheArgumentsStayForTheOp) {
  const std::string text =
      R"({"id": "a17", "op": "move", "position_mm": 150, "valid_for": 2.5, "issued_at": 1767949999.5})";
  const auto c = parse_envelope(at_now(text), 5);
  ASSERT_TRUE(c);
  EXPECT_EQ(c->id, "a17");
  EXPECT_EQ(c->id_key, "a17");
  EXPECT_EQ(c->op, "move");
  EXPECT_EQ(c->valid_for_s, 2.5);
  EXPECT_EQ(c->issued_at, 1767949999.5);
  // The envelope keys are not the op's arguments; the rest are.
  const auto cmd = parse_command(c->op, c->payload);
  ASSERT_TRUE(cmd);
  EXPECT_EQ(cmd->move.position_001mm, 15000);
}

TEST(MqttEnvelope, IntegerIdsAreEchoedAsGiven) {
  const auto c = parse_envelope(at_now(R"({"id": 42, "op": "stop"})"), 5);
  ASSERT_TRUE(c);
  EXPECT_EQ(c->id, 42);
  EXPECT_EQ(c->id_key, "42");
  EXPECT_EQ(c->valid_for_s, 5);  // the default
  EXPECT_FALSE(c->issued_at);
}

TEST(MqttEnvelope, MistakesNameTheField) {
  EXPECT_THAT(envelope_error("").message, HasSubstr("empty"));
  EXPECT_THAT(envelope_error("{nope").message, HasSubstr("not valid JSON"));
  EXPECT_THAT(envelope_error("[1, 2]").message, HasSubstr("JSON object"));
  EXPECT_EQ(envelope_error(R"({"op": "stop"})").field, "id");
  EXPECT_EQ(envelope_error(R"({"id": 1.5, "op": "stop"})").field, "id");
  EXPECT_EQ(envelope_error(R"({"id": "", "op": "stop"})").field, "id");
  EXPECT_EQ(envelope_error(R"({"id": ")" + std::string(129, 'x') + R"(", "op": "stop"})").field,
            "id");
  const auto no_op = envelope_error(R"({"id": "x"})");
  EXPECT_EQ(no_op.field, "op");
  EXPECT_EQ(no_op.id, "x");  // the result can still name the command
  EXPECT_EQ(envelope_error(R"({"id": "x", "op": 3})").field, "op");
  EXPECT_EQ(envelope_error(R"({"id": "x", "op": "stop", "valid_for": 0})").field, "valid_for");
  EXPECT_EQ(envelope_error(R"({"id": "x", "op": "stop", "valid_for": 3601})").field, "valid_for");
  EXPECT_EQ(envelope_error(R"({"id": "x", "op": "stop", "valid_for": "5"})").field, "valid_for");
  EXPECT_EQ(envelope_error(R"({"id": "x", "op": "stop", "issued_at": "now"})").field, "issued_at");
  EXPECT_EQ(envelope_error(R"({"id": "x", "op": "stop", "issued_at": -1})").status, 400);
}

std::optional<EnvelopeError> freshness(const std::string& payload, Received r) {
  r.payload = payload;
  const auto c = parse_envelope(r, 5);
  EXPECT_TRUE(c) << payload;
  return c ? check_fresh(*c, r) : std::nullopt;
}

TEST(MqttFreshness, IssuedAtOlderThanValidForIsRefused) {
  const Received now = at_now("");
  EXPECT_FALSE(freshness(R"({"id": 1, "op": "stop", "issued_at": 1767949995.5})", now));
  const auto stale = freshness(R"({"id": 1, "op": "stop", "issued_at": 1767949994.5})", now);
  ASSERT_TRUE(stale);
  EXPECT_EQ(stale->status, 408);
  EXPECT_EQ(stale->field, "issued_at");
  EXPECT_THAT(stale->message, HasSubstr("issued 5.5 s ago, valid for 5 s"));
  // valid_for given by the sender replaces the default.
  EXPECT_FALSE(
      freshness(R"({"id": 1, "op": "stop", "issued_at": 1767949990, "valid_for": 30})", now));
  EXPECT_TRUE(
      freshness(R"({"id": 1, "op": "stop", "issued_at": 1767949999, "valid_for": 0.5})", now));
}

TEST(MqttFreshness, IssuedFarInTheFutureMeansTheClocksDisagree) {
  const Received now = at_now("");
  EXPECT_FALSE(freshness(R"({"id": 1, "op": "stop", "issued_at": 1767950004})", now));
  const auto ahead = freshness(R"({"id": 1, "op": "stop", "issued_at": 1767950060})", now);
  ASSERT_TRUE(ahead);
  EXPECT_EQ(ahead->field, "issued_at");
  EXPECT_THAT(ahead->message, HasSubstr("clock"));
}

TEST(MqttFreshness, MessageExpiryWithinValidForIsTheBrokersPromise) {
  Received r = at_now("");
  r.expiry_s = 4;
  EXPECT_FALSE(freshness(R"({"id": 1, "op": "stop"})", r));
  r.expiry_s = 600;
  const auto weak = freshness(R"({"id": 1, "op": "stop"})", r);
  ASSERT_TRUE(weak);
  EXPECT_EQ(weak->field, "message_expiry");
  EXPECT_EQ(weak->status, 408);
  // issued_at, when given, is what counts.
  EXPECT_FALSE(freshness(R"({"id": 1, "op": "stop", "issued_at": 1767949999})", r));
}

TEST(MqttFreshness, WithNeitherTheAgeStartsAtReceipt) {
  EXPECT_FALSE(freshness(R"({"id": 1, "op": "stop"})", at_now("")));
}

// What is left of a command's validity bounds how long it may wait for a
// stop accepted before it (Command::start_by, Operations).
TEST(MqttFreshness, WhatIsLeftOfValidForBoundsTheWaitBeforeItStarts) {
  const Received now = at_now("");
  const auto aged = [&](const char* payload) {
    Received r = now;
    r.payload = payload;
    const auto c = parse_envelope(r, 5);
    EXPECT_TRUE(c) << payload;
    return c ? seconds_valid(*c, r) : -1.0;
  };
  EXPECT_DOUBLE_EQ(aged(R"({"id": 1, "op": "move"})"), 5.0);
  EXPECT_DOUBLE_EQ(aged(R"({"id": 1, "op": "move", "valid_for": 2})"), 2.0);
  EXPECT_NEAR(aged(R"({"id": 1, "op": "move", "issued_at": 1767949998.5})"), 3.5, 1e-6);
  // A sender a little ahead of this box: not more than valid_for.
  EXPECT_DOUBLE_EQ(aged(R"({"id": 1, "op": "move", "issued_at": 1767950001})"), 5.0);
}

TEST(MqttFreshness, RetainedCommandsAreRefusedWhateverTheirAge) {
  Received r = at_now("");
  r.retained = true;
  const auto e = freshness(R"({"id": 1, "op": "stop", "issued_at": 1767950000})", r);
  ASSERT_TRUE(e);
  EXPECT_EQ(e->field, "retain");
  EXPECT_EQ(e->id, 1);
}

}  // namespace
}  // namespace lec6::serve
