// A stop judged by the axis (client/stop.hpp), on the twin and the virtual
// clock: a RESET left at 1 by another client, an axis held at rest, a HOLD,
// a jog whose button another client keeps pressed (the RESET pulse does not
// end it: the stop escalates), a controller that does not answer.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "client/sim_fixture.hpp"
#include "lec6/client/stop.hpp"

namespace lec6::client {
namespace {

using ::testing::HasSubstr;
using namespace std::chrono_literals;
using lec6::testing::SimFixture;

DirectMove slow_move(int32_t to_001mm) {
  DirectMove m;
  m.position_001mm = to_001mm;
  m.speed_mm_s = 20;
  return m;
}

// Starts a slow move and lets it run for `for_`.
void moving(SimFixture& f, Duration for_ = 1s) {
  f.axis->start(slow_move(30000));
  f.client->idle_until(f.clock.now() + for_);
  ASSERT_TRUE(f.client->read_flags().busy());
  ASSERT_GT(f.client->read_state().speed_mm_s, 0);
}

TEST(StopJudge, ARESETLeftAtOneByAnotherClientIsReleasedFirstAndTheAxisStops) {
  SimFixture f;
  f.prepare();
  f.client->write_coil(lec::Coil::RESET, true);  // an HMI's maintained button, left at 1
  moving(f);                                     // a move starts all the same
  const auto r = f.axis->stop(StopKind::Stop, {});
  EXPECT_TRUE(r.stopped) << r.describe();
  EXPECT_THAT(r.describe(), HasSubstr("RESET pulse again (RESET may have been left at 1)"));
  EXPECT_FALSE(f.client->read_flags().busy());
  const auto at = f.client->read_state().position_001mm;
  f.client->idle_until(f.clock.now() + 1s);
  EXPECT_EQ(f.client->read_state().position_001mm, at) << "the axis went on moving";
  EXPECT_FALSE(f.client->read_controls().test(lec::Coil::RESET));
}

TEST(StopJudge, AStopOnAnAxisAtRestSaysWhereItIs) {
  SimFixture f;
  f.prepare();
  const auto r = f.axis->stop(StopKind::Stop, {});
  EXPECT_TRUE(r.stopped);
  EXPECT_THAT(r.describe(), HasSubstr("stopped at"));
  EXPECT_EQ(r.actions, std::vector<std::string>{"RESET pulse"})
      << "nothing read before the edge, and no second pulse when the first stopped it";
}

TEST(StopJudge, AHoldIsJudgedBySpeedAndTheMoveResumesAfterIt) {
  SimFixture f;
  f.prepare();
  moving(f);
  const auto r = f.axis->stop(StopKind::Hold, {});
  EXPECT_TRUE(r.stopped) << r.describe();
  EXPECT_THAT(r.describe(), HasSubstr("held at"));
  EXPECT_EQ(f.client->read_state().speed_mm_s, 0);
  f.axis->hold(false);
  f.client->idle_until(f.clock.now() + 500ms);
  EXPECT_GT(f.client->read_state().speed_mm_s, 0) << "HOLD off resumes the move";
}

TEST(StopJudge, AHoldOnAnAxisAlreadyHeldNeverReleasesIt) {
  SimFixture f;
  f.prepare();
  moving(f);
  f.axis->hold(true);
  f.client->idle_until(f.clock.now() + 500ms);
  ASSERT_EQ(f.client->read_state().speed_mm_s, 0);
  f.sent.clear();
  const auto r = f.axis->stop(StopKind::Hold, {});
  EXPECT_TRUE(r.stopped) << r.describe();
  for (const auto& frame : f.sent) {
    const bool hold_off =
        frame.size() >= 6 && frame[1] == 0x05 && frame[3] == 0x18 && frame[4] == 0;
    EXPECT_FALSE(hold_off) << "HOLD <- 0 was written: it resumes the held move";
  }
}

// A controller that answers RESET writes but does not act on them (a worn
// input stage, a firmware in another mode: what the judgement exists for):
// a master in front of the twin answers them itself.
class DeafToReset : public Master {
 public:
  explicit DeafToReset(Master& inner) : inner_(inner) {}
  modbus::ResponseFrame exchange(const modbus::RequestFrame& frame) override {
    if (const auto* w = std::get_if<modbus::WriteCoilRequest>(&frame.pdu);
        w && w->coil == lec::address(lec::Coil::RESET)) {
      return {frame.id, modbus::WriteCoilResponse{w->coil, w->value}};
    }
    return inner_.exchange(frame);
  }
  const Clock& clock() const override { return inner_.clock(); }
  std::string describe() const override { return "deaf to RESET"; }
  LinkStats stats() const override { return inner_.stats(); }
  Duration last_round_trip() const override { return inner_.last_round_trip(); }
  const modbus::LineTiming& line_timing() const override { return inner_.line_timing(); }
  void idle_until(TimePoint t) override { inner_.idle_until(t); }

 private:
  Master& inner_;
};

TEST(StopJudge, AnAxisThatKeepsMovingAfterTheStopEscalatesAndSaysSo) {
  SimFixture f;
  f.prepare();
  moving(f);
  DeafToReset deaf(f.client->master());
  Client c(deaf);
  Actuator act(c);
  StopPolicy p;
  p.escalate_hold = false;
  const auto plain = act.stop(StopKind::Stop, p);
  EXPECT_FALSE(plain.stopped);
  EXPECT_THAT(plain.describe(), HasSubstr("RESET pulse again"));
  EXPECT_THAT(plain.describe(), HasSubstr("still moving at 20 mm/s"));
  const auto escalated = act.stop(StopKind::Stop, {});
  EXPECT_TRUE(escalated.stopped) << escalated.describe();
  EXPECT_THAT(escalated.describe(), HasSubstr("HOLD <- 1"));
  EXPECT_EQ(f.client->read_state().speed_mm_s, 0);
}

TEST(StopJudge, AControllerThatDoesNotAnswerIsNotCalledStopped) {
  SimFixture f;
  ClientOptions o;
  o.id = 9;  // nothing at ID 9
  f.reconnect(o);
  const TimePoint began = f.clock.now();
  const auto r = f.axis->stop(StopKind::Stop, {});
  EXPECT_FALSE(r.stopped);
  EXPECT_FALSE(r.answered);
  EXPECT_THAT(r.describe(), HasSubstr("could not be read"));
  EXPECT_LT(f.clock.now() - began, 5s) << "bounded";
}

}  // namespace
}  // namespace lec6::client
