// Attacks on the move settings' provenance (dcmd.hpp: record_settings,
// settle_settings; docs/sparkplug.md: "A move the axis itself refuses before
// anything reaches the wire (servo off, 409) gives back the settings its DCMD
// set — those a later DCMD has not set since"), from a review of the fix.
//
// The node (edge_node_commands.cpp, Core::command) plans a DCMD on the
// current settings under the node's mutex, releases it, and records the
// plan's settings under the mutex again; an action's result comes back on an
// operation's thread (finished() -> settle_settings), in any order and at any
// moment between the two.

#include <gtest/gtest.h>

#include "sparkplug/dcmd.hpp"

namespace lec6::serve::sparkplug {
namespace settings_attack {

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

// What Core::command() does with a DCMD numbered `count`: plan on the current
// settings, record, and settle at once when it is settings alone.
Plan plan_of(const CommandState& s, std::vector<Write> writes) {
  auto p = plan(writes, s.move);
  EXPECT_TRUE(p) << p.error();
  return p ? *p : Plan{};
}

// A later DCMD writes the same value a move in flight wrote: it set it, and
// its outcome says "move settings kept"; the move is then refused by the axis
// (servo off) and takes the value back with it, because record_settings()
// marks only the fields whose value changed.
TEST(SparkplugDcmdSettingsAttack, ARefusedMoveDoesNotTakeBackWhatALaterDcmdWroteTheSame) {
  CommandState s;
  // DCMD 1: move to 100 at 30 mm/s (in flight: the axis has not answered yet).
  record_settings(
      s, 1,
      plan_of(s, {w("Command/Move/Position mm", 100.0), w("Command/Move/Speed mm/s", int64_t{30}),
                  w("Command/Move/Execute", true)}));
  // DCMD 2: settings alone, speed 30 (the value the operator wants from now on): kept.
  record_settings(s, 2, plan_of(s, {w("Command/Move/Speed mm/s", int64_t{30})}));
  settle_settings(s, 2, false);
  // DCMD 1's move is refused before the wire (servo off).
  settle_settings(s, 1, true);
  EXPECT_FALSE(s.move.position_mm.has_value()) << "the refused move's position stays";
  EXPECT_EQ(s.move.speed_mm_s, std::optional<int64_t>(30))
      << "DCMD 2 set speed 30 and was told 'move settings kept'; the refused DCMD 1 took it away";
}

// Two DCMDs with an action in flight, both refused before the wire, the
// earlier one's result first (both read the axis' controls at Command
// priority, in order: a move and a servo-on while the controller is in
// parallel mode). The later one gives back "the value before it", which is
// the earlier refused DCMD's: a refused DCMD's setting comes back.
TEST(SparkplugDcmdSettingsAttack, TwoRefusedDcmdsSettledInOrderKeepNothing) {
  CommandState s;
  record_settings(
      s, 1,
      plan_of(s, {w("Command/Move/Position mm", 100.0), w("Command/Move/Speed mm/s", int64_t{10}),
                  w("Command/Move/Execute", true)}));
  record_settings(
      s, 2, plan_of(s, {w("Command/Servo", true), w("Command/Move/Speed mm/s", int64_t{20})}));
  settle_settings(s, 1, true);  // the move: 409 parallel mode
  settle_settings(s, 2, true);  // the servo on: 409 parallel mode
  EXPECT_EQ(s.move, MoveSettings{}) << "speed " << s.move.speed_mm_s.value_or(-1)
                                    << " (DCMD 1's, refused) is kept after both were refused";
  EXPECT_TRUE(s.pending.empty());
}

// The same two refused DCMDs, results in the other order: this one holds.
TEST(SparkplugDcmdSettingsAttack, TwoRefusedDcmdsSettledInReverseKeepNothing) {
  CommandState s;
  record_settings(
      s, 1,
      plan_of(s, {w("Command/Move/Position mm", 100.0), w("Command/Move/Speed mm/s", int64_t{10}),
                  w("Command/Move/Execute", true)}));
  record_settings(
      s, 2, plan_of(s, {w("Command/Servo", true), w("Command/Move/Speed mm/s", int64_t{20})}));
  settle_settings(s, 2, true);
  settle_settings(s, 1, true);
  EXPECT_EQ(s.move, MoveSettings{});
  EXPECT_TRUE(s.pending.empty());
}

// Core::command() plans under the mutex, lets it go (number(), the second
// overtaken() check), and records under it again. A refusal that comes back
// in between (finished() on the operation's thread) gives the settings back;
// the record then writes the stale plan, refused settings included, as the
// later DCMD's own: never given back.
TEST(SparkplugDcmdSettingsAttack, ARefusalBetweenPlanAndRecordIsNotUndone) {
  CommandState s;
  record_settings(
      s, 1,
      plan_of(s, {w("Command/Move/Position mm", 100.0), w("Command/Move/Speed mm/s", int64_t{10}),
                  w("Command/Move/Execute", true)}));
  // DCMD 2 (acceleration alone) is planned on DCMD 1's settings...
  const Plan planned = plan_of(s, {w("Command/Move/Accel mm/s2", int64_t{200})});
  // ...DCMD 1's refusal comes back now (the mutex is free)...
  settle_settings(s, 1, true);
  // ...and DCMD 2 is recorded.
  record_settings(s, 2, planned);
  settle_settings(s, 2, false);
  EXPECT_FALSE(s.move.position_mm.has_value()) << "the refused move's position came back";
  EXPECT_FALSE(s.move.speed_mm_s.has_value()) << "the refused move's speed came back";
  EXPECT_EQ(s.move.accel_mm_s2, std::optional<int64_t>(200));
}

// Memory: every record is settled, whatever the order: nothing left in `before`.
TEST(SparkplugDcmdSettingsAttack, ProvenanceIsEmptyOnceEveryDcmdIsSettled) {
  CommandState s;
  for (int64_t n = 1; n <= 1000; ++n) {
    record_settings(s, n, plan_of(s, {w("Command/Move/Speed mm/s", int64_t{1 + n % 500})}));
  }
  EXPECT_EQ(s.pending.size(), 1000u);  // one per DCMD in flight
  for (int64_t n = 1000; n >= 1; n -= 2) settle_settings(s, n, n % 4 == 0);
  for (int64_t n = 1; n <= 1000; n += 2) settle_settings(s, n, false);
  EXPECT_TRUE(s.pending.empty());
}

}  // namespace settings_attack
}  // namespace lec6::serve::sparkplug
