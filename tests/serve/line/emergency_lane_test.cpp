// The emergency lane (line/emergency_lane.hpp) through the scheduler, on a
// virtual clock: per-controller fairness with a dead neighbour, coalescing of
// a PLC's repeated image writes, backoff, a stop never cancelled, and stops
// during shutdown (issue 31 rules 2 and 4).

#include <gtest/gtest.h>

#include <random>

#include "serve/line/scheduler_harness.hpp"

namespace lec6::serve {
namespace {

using namespace scheduler_testing;

const modbus::Request kLaneResetOn = modbus::WriteCoilRequest{0x1B, modbus::kCoilOn};
const modbus::Request kLaneHoldOn = modbus::WriteCoilRequest{0x18, modbus::kCoilOn};
const modbus::Request kLaneServoOff = modbus::WriteCoilRequest{0x19, modbus::kCoilOff};

constexpr Duration kAnswered = 10ms;  // the harness's answered exchange
constexpr Duration kDead = 65ms;      // and its unanswered one

// A plant: ID 2 dead; a PLC writes SVON = 0 to it every 100 ms (its output
// image, a stop by the one rule); ID 3 answers and gets a HOLD image every
// 30 ms; SCADA floods ID 1 and 3 with reads. The operator's stops for ID 1
// come at random moments. Each must reach the wire within the transaction
// on it, one dead exchange and one exchange per other answering controller
// with a stop queued (here: ID 3): 10 + 65 + 10 ms.
TEST(EmergencyLane, ADeadNeighboursStopsCostAnotherAxisAtMostOneDeadExchange) {
  for (uint32_t seed = 1; seed <= 20; ++seed) {
    SchedulerConfig c;
    c.axes = {{1, 100ms}, {2, 100ms}, {3, 100ms}};
    Harness h(c);
    std::mt19937 rng(seed);
    TimePoint next_plc = h.clock.now(), next_hold = h.clock.now(), next_stop = h.clock.now() + 1s;
    const TimePoint end = h.clock.now() + 10s;
    std::map<JobId, TimePoint> operator_stops;
    Duration worst{};
    int sent_stops = 0;
    while (h.clock.now() < end) {
      const TimePoint now = h.clock.now();
      if (now >= next_plc) {
        h.s.submit(h.job(Priority::Emergency, 2, kLaneServoOff), now);
        next_plc = now + 100ms;
      }
      if (now >= next_hold) {
        h.s.submit(h.job(Priority::Emergency, 3, kLaneHoldOn), now);
        next_hold = now + 30ms;
      }
      if (h.s.queue_depth()[index(Priority::Command)] < 50) {
        h.s.submit(h.job(Priority::Command, 1 + 2 * (rng() % 2)), now);
      }
      if (now >= next_stop) {
        operator_stops[h.s.submit(h.job(Priority::Emergency, 1, kLaneResetOn), now)] = now;
        next_stop = now + std::chrono::milliseconds(200 + rng() % 800);
      }
      auto d = h.s.next(now);
      if (!d) {
        const auto w = h.s.wake_at();
        h.clock.set(std::max(now + 1ms, std::min(w.value_or(now + 1ms), next_plc)));
        continue;
      }
      if (const auto it = operator_stops.find(d->id); it != operator_stops.end()) {
        worst = std::max(worst, h.clock.now() - it->second);
        operator_stops.erase(it);
        ++sent_stops;
      }
      const TimePoint start = h.clock.now();
      const bool dead = d->frame.id == 2;
      h.clock.advance(dead ? kDead : kAnswered);
      dead ? h.s.failed(kTimeout, start, h.clock.now())
           : h.s.completed(answer(*d), start, h.clock.now());
      for (auto& x : h.s.take_completions()) x.done(x.result);
    }
    EXPECT_GE(sent_stops, 8) << "seed " << seed;
    EXPECT_LE(worst, kAnswered + kDead + kAnswered) << "seed " << seed;
    EXPECT_LE(h.s.queue_depth()[index(Priority::Emergency)], 3u)
        << "seed " << seed << ": the PLC's repeated writes piled up";
  }
}

TEST(EmergencyLane, IdenticalStopsToOneControllerCoalesceAndAllAreAnswered) {
  Harness h;
  h.s.submit(h.job(Priority::Command, 5), h.clock.now());
  ASSERT_TRUE(h.s.next(h.clock.now()));  // something on the wire
  for (int i = 0; i < 100; ++i)
    h.s.submit(h.job(Priority::Emergency, 2, kLaneServoOff), h.clock.now());
  h.s.submit(h.job(Priority::Emergency, 2, kLaneHoldOn), h.clock.now());
  EXPECT_EQ(h.s.queue_depth()[index(Priority::Emergency)], 2u) << "one SVON write, one HOLD";
  h.clock.advance(10ms);
  h.s.completed(answer(Dispatch{0, {5, kReadState}, Priority::Command}), h.clock.now() - 10ms,
                h.clock.now());
  for (auto& x : h.s.take_completions()) x.done(x.result);
  h.results.clear();
  EXPECT_TRUE(h.step());
  EXPECT_TRUE(h.step());
  EXPECT_EQ(h.results.size(), 101u) << "every submitter answered";
  for (const auto& r : h.results) EXPECT_EQ(r.failure, Failure::None);
}

TEST(EmergencyLane, AnAnsweringControllersStopsNeverStarveADeadOnes) {
  SchedulerConfig c;
  c.emergency_attempts = 3;
  Harness h(c);
  const JobId dead_stop = h.s.submit(h.job(Priority::Emergency, 2, kLaneHoldOn), h.clock.now());
  (void)dead_stop;
  int dead_attempts = 0;
  for (int i = 0; i < 400 && h.results.size() < 200; ++i) {
    // A stream of distinct stops to ID 1, always one queued.
    h.s.submit(h.job(Priority::Emergency, 1, i % 2 ? kLaneResetOn : kLaneHoldOn), h.clock.now());
    if (auto d = h.step({2})) {
      dead_attempts += d->frame.id == 2;
    } else {
      h.clock.advance(5ms);
    }
  }
  EXPECT_EQ(dead_attempts, 3) << "the dead controller's stop kept its attempts";
}

TEST(EmergencyLane, AnAcceptedStopIsNeverCancelled) {
  Harness h;
  const JobId stop = h.s.submit(h.job(Priority::Emergency, 1, kLaneHoldOn), h.clock.now());
  EXPECT_FALSE(h.s.cancel(stop, h.clock.now())) << "its connection closed: the HOLD stays";
  const auto d = h.step();
  ASSERT_TRUE(d);
  EXPECT_EQ(d->frame.pdu, kLaneHoldOn);
  ASSERT_EQ(h.results.size(), 1u);
  EXPECT_EQ(h.results[0].failure, Failure::None);
}

TEST(EmergencyLane, StopsAreTakenAndSentWhileTheLineShutsDown) {
  SchedulerConfig c;
  c.axes = {{1, 100ms}};
  Harness h(c);
  h.s.submit(h.job(Priority::Command, 1), h.clock.now());
  h.s.submit(h.job(Priority::Emergency, 1, kLaneHoldOn), h.clock.now());
  h.s.begin_shutdown(h.clock.now());
  h.s.submit(h.job(Priority::Completion, 1), h.clock.now());
  h.s.submit(h.job(Priority::Emergency, 1, kLaneResetOn), h.clock.now());
  for (auto& x : h.s.take_completions()) x.done(x.result);
  ASSERT_EQ(h.results.size(), 2u) << "the read queued and the poll submitted: refused";
  for (const auto& r : h.results) EXPECT_EQ(r.failure, Failure::ShuttingDown);
  EXPECT_FALSE(h.s.drained());
  const auto a = h.step();
  const auto b = h.step();
  ASSERT_TRUE(a && b);
  EXPECT_EQ(a->frame.pdu, kLaneHoldOn);
  EXPECT_EQ(b->frame.pdu, kLaneResetOn);
  EXPECT_FALSE(h.step()) << "no telemetry while shutting down";
  EXPECT_TRUE(h.s.drained());
  h.s.shut_down(h.clock.now());
  h.s.submit(h.job(Priority::Emergency, 1, kLaneResetOn), h.clock.now());
  for (auto& x : h.s.take_completions()) x.done(x.result);
  EXPECT_EQ(h.results.back().failure, Failure::ShuttingDown) << "the line has closed";
}

}  // namespace
}  // namespace lec6::serve
