// Issue 32, rule 1: a move is dated by when its exchanges were on the wire,
// not by when their replies reached the thread that polls. A master whose
// replies wait in a queue before the caller sees them (lec serve's busy
// line: the line's thread is done, the operation's thread not yet woken)
// must not shift the moves' BUSY edges out of their brackets. The twin's own
// record of each move (OperationRecord) is the truth.

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "lec6/client/rtu_master.hpp"
#include "sim_fixture.hpp"

namespace lec6::client {
namespace {

using testing::SimFixture;

// An RtuMaster whose replies reach the caller 0-40 ms after their last byte
// (seeded): the virtual clock runs on meanwhile, and the twin with it.
class QueuedMaster final : public Master {
 public:
  QueuedMaster(Link& link, VirtualClock& clock, bool tells_wire_times)
      : inner_(link), clock_(clock), tells_(tells_wire_times) {}
  modbus::ResponseFrame exchange(const modbus::RequestFrame& frame) override {
    auto reply = inner_.exchange(frame);
    clock_.advance(to_duration(FractionalMilliseconds(queue_(rng_))));
    return reply;
  }
  const Clock& clock() const override { return inner_.clock(); }
  std::string describe() const override { return "queued " + inner_.describe(); }
  LinkStats stats() const override { return inner_.stats(); }
  Duration last_round_trip() const override { return inner_.last_round_trip(); }
  std::optional<WireTimes> last_wire_times() const override {
    return tells_ ? inner_.last_wire_times() : std::nullopt;
  }
  const modbus::LineTiming& line_timing() const override { return inner_.line_timing(); }
  void idle_until(TimePoint t) override { inner_.idle_until(t); }

 private:
  RtuMaster inner_;
  VirtualClock& clock_;
  bool tells_;
  std::mt19937 rng_{32};
  std::uniform_real_distribution<double> queue_{0, 40};
};

struct Misses {
  int moves = 0, outside = 0;
  double worst_ms = 0;
};

// 40 short moves back and forth; how many read outside their bracket.
Misses run(bool wire_times) {
  SimFixture f;
  QueuedMaster master(*f.link, f.clock, wire_times);
  Client client(master);
  Actuator axis(client);
  axis.set_serial_mode(true);
  axis.servo_on(axis.deadline_in(std::chrono::seconds(2)));
  axis.home(axis.deadline_in(std::chrono::seconds(60)));
  Misses m;
  for (int i = 0; i < 40; ++i) {
    DirectMove d;
    d.position_001mm = i % 2 == 0 ? 2000 : 500;  // 15 mm: about 0.2 s
    d.speed_mm_s = 100;
    const MoveResult r = axis.move(d, axis.deadline_in(std::chrono::seconds(5)));
    EXPECT_EQ(r.outcome, MoveOutcome::Reached);
    const auto& truth = f.bus.find(1)->operations().back();
    const MoveTimeline& t = r.timeline;
    if (!truth.busy_rose || !truth.busy_fell || !t.busy_up || !t.busy_down || !t.busy_up_after ||
        !t.busy_down_after) {
      ADD_FAILURE() << "move " << i << " lacks an edge";
      continue;
    }
    const double up = to_seconds(*t.busy_up + *t.busy_up_after) / 2;
    const double down = to_seconds(*t.busy_down + *t.busy_down_after) / 2;
    const double pm =
        to_seconds((*t.busy_up - *t.busy_up_after) + (*t.busy_down - *t.busy_down_after)) / 2;
    const double real = to_seconds(*truth.busy_fell - *truth.busy_rose);
    const double error = std::abs((down - up) - real);
    ++m.moves;
    if (error > pm + 1e-9) ++m.outside;
    m.worst_ms = std::max(m.worst_ms, 1000 * error);
  }
  return m;
}

TEST(WireDating, AQueueAfterTheReplyLeavesEveryDurationWithinItsBracket) {
  const Misses wire = run(true);
  EXPECT_EQ(wire.moves, 40);
  EXPECT_EQ(wire.outside, 0) << "worst error " << wire.worst_ms << " ms";
  // Dated by the replies' arrival instead, the same queue puts edges outside
  // the brackets (what the line's wire times fix; and what makes this test
  // able to fail).
  const Misses arrival = run(false);
  EXPECT_GT(arrival.outside, 0);
  RecordProperty("worst_error_ms_wire_dated", std::to_string(wire.worst_ms));
  RecordProperty("worst_error_ms_arrival_dated", std::to_string(arrival.worst_ms));
}

}  // namespace
}  // namespace lec6::client
