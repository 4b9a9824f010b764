// Stops through lec serve's operations, on a real Line and the built-in twin
// (fast timing) on the wall clock (issue 31 rules 1, 4 and 6): a stop is
// judged by the axis and says where it stopped; a RESET left at 1 by another
// client does not make "stopped" a lie; a stop ends a jog; stops are taken
// while the daemon shuts down. The waits are on results and polled state
// with deadlines, never sleeps.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "serve/ops/twin_directory.hpp"

namespace lec6::serve {
namespace {

using namespace std::chrono_literals;
using testing::eventually;
using ::testing::HasSubstr;
using testing::TwinDirectory;

// Direct-data fields of a slow move (about 15 s at 20 mm/s).
nlohmann::json slow_move() {
  return {{"position_mm", 350}, {"speed_mm_s", 20}, {"timeout_s", 60}};
}

TEST(OperationsStop, AStopIsJudgedByTheAxisAndSaysWhereItStopped) {
  TwinDirectory d;
  d.prepare(d.axis1());
  auto move = d.start(d.axis1(), "move", slow_move());
  ASSERT_TRUE(eventually([&] { return d.moving(d.axis1()); }));
  // An HMI's maintained RESET button: a write of 1 over a 1 is no edge.
  Job hmi;
  hmi.priority = Priority::Command;
  hmi.frame = {1, modbus::WriteCoilRequest{0x1B, modbus::kCoilOn}};
  d.line1().submit(std::move(hmi));
  const OpResult stop = d.run(d.axis1(), "stop");
  EXPECT_EQ(stop.status, 200) << stop.body.dump();
  EXPECT_THAT(stop.body.value("message", ""), HasSubstr("stopped at"));
  EXPECT_TRUE(stop.body.value("stopped", false));
  EXPECT_EQ(stop.body["speed_mm_s"], 0);
  ASSERT_EQ(move.wait_for(20s), std::future_status::ready);
  EXPECT_EQ(move.get().body.value("outcome", ""), "stopped");
  EXPECT_FALSE(d.moving(d.axis1()));
}

TEST(OperationsStop, AStopEndsAJogAtOnce) {
  TwinDirectory d;
  d.prepare(d.axis1());
  // A jog without a lease: it runs until released.
  auto jog = d.start(d.axis1(), "jog", {{"direction", "+"}, {"duration_ms", 30000}});
  ASSERT_TRUE(eventually([&] { return d.moving(d.axis1()); }));
  const OpResult stop = d.run(d.axis1(), "stop");
  EXPECT_EQ(stop.status, 200) << stop.body.dump();
  ASSERT_EQ(jog.wait_for(10s), std::future_status::ready) << "the jog went on after the stop";
  EXPECT_FALSE(d.ops.running(d.axis1())) << "the motion slot is free";
  EXPECT_EQ(d.run(d.axis1(), "move", {{"position_mm", 20}, {"speed_mm_s", 100}}).status, 200)
      << "a new motion is accepted";
}

TEST(OperationsStop, StopsAreTakenWhileShuttingDownAndOtherCommandsAreNot) {
  TwinDirectory d;
  d.prepare(d.axis1());
  auto move = d.start(d.axis1(), "move", slow_move());
  ASSERT_TRUE(eventually([&] { return d.moving(d.axis1()); }));
  d.ops.begin_shutdown();
  const OpResult refused = d.run(d.axis2(), "home");
  EXPECT_EQ(refused.status, 503);
  const OpResult stop = d.run(d.axis1(), "stop");
  EXPECT_EQ(stop.status, 200) << stop.body.dump();
  EXPECT_FALSE(d.moving(d.axis1()));
  ASSERT_EQ(move.wait_for(20s), std::future_status::ready);
}

TEST(OperationsStop, TheLineSendsTheStopsQueuedWhenItCloses) {
  TwinDirectory d;
  d.prepare(d.axis1());
  auto move = d.start(d.axis1(), "move", slow_move());
  ASSERT_TRUE(eventually([&] { return d.moving(d.axis1()); }));
  d.line1().begin_stop();
  std::promise<JobResult> answered;
  Job hold;
  hold.priority = Priority::Emergency;
  hold.frame = {1, modbus::WriteCoilRequest{0x18, modbus::kCoilOn}};
  hold.done = [&](const JobResult& r) { answered.set_value(r); };
  d.line1().submit(std::move(hold));
  d.line1().stop();
  auto f = answered.get_future();
  ASSERT_EQ(f.wait_for(5s), std::future_status::ready);
  EXPECT_EQ(f.get().failure, Failure::None) << "the HOLD was dropped by the shutdown";
  move.wait_for(20s);
}

}  // namespace
}  // namespace lec6::serve
