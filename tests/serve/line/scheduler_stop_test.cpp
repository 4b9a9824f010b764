// A stop always reaches the controller: the scheduler's rules for Emergency
// jobs (stop, hold, reset), on a virtual clock. Each test names a way the
// line can struggle; in each, the stop still goes to the wire.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "lec6/client/interrupt.hpp"
#include "lec6/error.hpp"
#include "line/line_master.hpp"
#include "modbus_tcp/gateway.hpp"
#include "serve/line/scheduler_harness.hpp"

namespace lec6::serve {
namespace {

using namespace scheduler_testing;
using ::testing::HasSubstr;

const modbus::Request kResetOn = modbus::WriteCoilRequest{0x1B, modbus::kCoilOn};

// Makes ID 9 offline: `offline_after` failed exchanges.
void take_offline(Harness& h, uint8_t id = 9) {
  while (!h.s.health(id).offline) {
    h.s.submit(h.job(Priority::Command, id), h.clock.now());
    h.step({id});
  }
  h.results.clear();
}

// The time one exchange takes in the harness (10 ms answered, 65 ms dead).
constexpr Duration kTransaction = 65ms;

TEST(SchedulerStop, AStopToAnOfflineControllerReachesTheWireWithinOneTransactionTime) {
  Harness h;
  take_offline(h);
  // A client read is refused at once, as before …
  h.s.submit(h.job(Priority::Command, 9), h.clock.now());
  for (auto& x : h.s.take_completions()) x.done(x.result);
  ASSERT_EQ(h.results.size(), 1u);
  EXPECT_EQ(h.results[0].failure, Failure::Offline);
  // … a stop is not: it is the next frame on the wire.
  const TimePoint posted = h.clock.now();
  h.s.submit(h.job(Priority::Emergency, 9, kResetOn), posted);
  EXPECT_TRUE(h.s.take_completions().empty()) << "refused at submit";
  const auto d = h.step();  // the controller hears it and answers this time
  ASSERT_TRUE(d);
  EXPECT_EQ(d->frame.pdu, kResetOn);
  EXPECT_LE(h.clock.now() - posted, kTransaction);
  EXPECT_EQ(h.results.back().failure, Failure::None);
  // It counted as a probe: the controller is back.
  EXPECT_FALSE(h.s.health(9).offline);
}

TEST(SchedulerStop, AStopQueuedBeforeTheControllerWentOfflineIsStillSent) {
  SchedulerConfig c;
  c.offline_after = 1;
  Harness h(c);
  h.s.submit(h.job(Priority::Command, 9), h.clock.now());
  ASSERT_TRUE(h.s.next(h.clock.now()));  // on the wire, about to fail
  h.s.submit(h.job(Priority::Command, 9), h.clock.now());
  h.s.submit(h.job(Priority::Emergency, 9, kResetOn), h.clock.now());
  h.clock.advance(65ms);
  h.s.failed(kTimeout, h.clock.now() - 65ms, h.clock.now());
  for (auto& x : h.s.take_completions()) x.done(x.result);
  ASSERT_TRUE(h.s.health(9).offline);
  ASSERT_EQ(h.results.size(), 2u);  // the read on the wire and the queued read: failed
  EXPECT_EQ(h.results[1].failure, Failure::Offline);
  const auto d = h.step();
  ASSERT_TRUE(d) << "the stop was dropped with the controller's other jobs";
  EXPECT_EQ(d->frame.pdu, kResetOn);
  EXPECT_EQ(h.results.back().failure, Failure::None);
}

TEST(SchedulerStop, ALostReplyDoesNotCostTheStop) {
  Harness h;
  take_offline(h);
  h.s.submit(h.job(Priority::Emergency, 9, kResetOn), h.clock.now());
  h.step({9});  // replies lost twice …
  EXPECT_FALSE(h.s.next(h.clock.now())) << "a non-answering controller's stop backs off";
  h.clock.advance(h.s.config().emergency_backoff);
  h.step({9});
  EXPECT_TRUE(h.results.empty()) << "the stop gave up after one attempt";
  h.clock.advance(h.s.config().emergency_backoff);
  const auto d = h.step();  // … the third attempt is answered
  ASSERT_TRUE(d);
  EXPECT_EQ(d->frame.pdu, kResetOn);
  ASSERT_EQ(h.results.size(), 1u);
  EXPECT_EQ(h.results[0].failure, Failure::None);
}

TEST(SchedulerStop, AStopThatNeverGetsAnAnswerSaysSoAfterItsAttempts) {
  SchedulerConfig c;
  c.emergency_attempts = 4;
  Harness h(c);
  take_offline(h);
  h.s.submit(h.job(Priority::Emergency, 9, kResetOn), h.clock.now());
  int sent = 0;
  for (int i = 0; i < 100 && h.results.empty(); ++i) {
    if (h.step({9})) {
      ++sent;
    } else {
      h.clock.advance(10ms);  // its backoff between attempts
    }
  }
  EXPECT_EQ(sent, 4);
  ASSERT_EQ(h.results.size(), 1u);
  EXPECT_EQ(h.results[0].failure, Failure::NoAnswer) << "not 'offline': it was sent";
}

TEST(SchedulerStop, OnlyAPortThatIsGoneOrAShutdownRefusesAStop) {
  Harness h;
  h.s.line_down("/dev/ttyUSB0: No such device (unplugged?)", h.clock.now());
  h.s.submit(h.job(Priority::Emergency, 1, kResetOn), h.clock.now());
  h.s.line_up(h.clock.now());
  h.s.shut_down(h.clock.now());
  h.s.submit(h.job(Priority::Emergency, 1, kResetOn), h.clock.now());
  for (auto& x : h.s.take_completions()) x.done(x.result);
  ASSERT_EQ(h.results.size(), 2u);
  EXPECT_EQ(h.results[0].failure, Failure::LineDown);
  EXPECT_THAT(h.results[0].error, HasSubstr("No such device"));
  EXPECT_EQ(h.results[1].failure, Failure::ShuttingDown);
  EXPECT_THAT(h.results[1].error, HasSubstr("shutting down"));
}

TEST(SchedulerStop, AStopGoesAheadOfStarvedPollsAndAFullQueue) {
  SchedulerConfig c;
  c.axes = {{1, 50ms}, {2, 50ms}};
  Harness h(c);
  for (int i = 0; i < 500; ++i) h.s.submit(h.job(Priority::Command, 2), h.clock.now());
  for (int i = 0; i < 20; ++i) h.s.submit(h.job(Priority::Completion, 1), h.clock.now());
  h.run_for(2s);  // every kind has waited past poll_max_wait: they take turns
  h.s.submit(h.job(Priority::Emergency, 1, kResetOn), h.clock.now());
  const auto d = h.step();
  ASSERT_TRUE(d);
  EXPECT_EQ(d->frame.pdu, kResetOn);
}

TEST(SchedulerStop, APlcResetOvertakesFiveHundredQueuedScadaReads) {
  Harness h;
  GatewayPolicy policy;
  policy.units = {1, 2};
  const auto submit = [&](uint8_t unit, modbus::Request r) {
    const auto pdu = *modbus::encode_request_pdu(r);
    const LineRequest line = std::get<LineRequest>(decide(policy, unit, pdu));
    Job j = h.job(line.priority, unit, line.frame.pdu);
    j.attempts = line.attempts;
    h.s.submit(std::move(j), h.clock.now());
  };
  for (int i = 0; i < 500; ++i) submit(2, modbus::ReadRegistersRequest{0x9000, 7});
  submit(1, kResetOn);
  const auto d = h.step();
  ASSERT_TRUE(d);
  EXPECT_EQ(d->frame.id, 1);
  EXPECT_EQ(d->frame.pdu, kResetOn);
  EXPECT_EQ(d->priority, Priority::Emergency);
}

// Every front-end classifies with the one rule (client::stops_or_releases):
// the daemon's operations (priority_of) and the Modbus TCP gateway agree.
TEST(SchedulerStop, TheGatewayAndOperationsClassifyWithTheOneRule) {
  GatewayPolicy policy;
  policy.units = {1};
  for (uint16_t coil : {0x18, 0x19, 0x1A, 0x1B, 0x1C, 0x1D, 0x1E, 0x30}) {
    for (bool on : {true, false}) {
      const modbus::Request r =
          modbus::WriteCoilRequest{coil, on ? modbus::kCoilOn : modbus::kCoilOff};
      const modbus::RequestFrame frame{1, r};
      const Priority ops = priority_of(frame, Priority::Completion, Priority::Command);
      const LineRequest line =
          std::get<LineRequest>(decide(policy, 1, *modbus::encode_request_pdu(r)));
      EXPECT_EQ(line.priority, ops) << "coil " << coil << " = " << on;
      EXPECT_EQ(ops == Priority::Emergency, client::stops_or_releases(r))
          << "coil " << coil << " = " << on;
    }
  }
}

TEST(SchedulerStop, AJobAtTelemetryPriorityIsRefusedAtSubmit) {
  Harness h;
  EXPECT_THROW(h.s.submit(h.job(Priority::Telemetry, 1), h.clock.now()), InvalidArgument);
  EXPECT_FALSE(h.s.next(h.clock.now())) << "it would never be taken, and the line would spin";
}

// The scheduler's own alarm-history read (Background) must not move an axis's
// telemetry schedule: the sample after it comes one period after the last.
TEST(SchedulerStop, ABackgroundReadDoesNotDelayTheTelemetrySample) {
  SchedulerConfig c;
  c.axes = {{1, 100ms}};
  Harness h(c);  // queues the alarm history read of ID 1 at start
  const auto sent = h.run_for(1s);
  std::size_t state_reads = 0;
  for (const auto& d : sent) {
    state_reads += d.priority == Priority::Telemetry &&
                   std::holds_alternative<modbus::ReadRegistersRequest>(d.frame.pdu);
  }
  // Ten periods in a second, one state read each: none skipped.
  EXPECT_GE(state_reads, 10u);
}

// The first attempt's wait (submit → on the wire) is what the stats report.
TEST(SchedulerStop, TheStatsSayHowLongAStopWaitedForTheWire) {
  Harness h;
  h.s.submit(h.job(Priority::Command, 2), h.clock.now());
  ASSERT_TRUE(h.s.next(h.clock.now()));  // a read on the wire
  h.s.submit(h.job(Priority::Emergency, 1, kResetOn), h.clock.now());
  h.clock.advance(10ms);
  h.s.completed(answer(Dispatch{0, {2, kReadState}, Priority::Command}), h.clock.now() - 10ms,
                h.clock.now());
  h.step();
  const auto s = h.s.stats(h.clock.now());
  EXPECT_NEAR(s.latency[index(Priority::Emergency)].wait_p99_ms, 10.0, 0.01);
  EXPECT_NEAR(s.latency[index(Priority::Emergency)].wait_max_ms, 10.0, 0.01);
}

}  // namespace
}  // namespace lec6::serve
