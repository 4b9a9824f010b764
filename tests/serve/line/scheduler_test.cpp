// The line scheduler on a virtual clock: priorities, telemetry round-robin,
// back-off of a dead controller, the cache, cancellation and shutdown. The
// "line" here is the test: it answers each dispatch by hand.

#include "line/scheduler.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "serve/line/scheduler_harness.hpp"

namespace lec6::serve {
namespace {

using namespace scheduler_testing;
using ::testing::HasSubstr;

TEST(Scheduler, ServesByPriorityThenInOrder) {
  Harness h;
  h.s.submit(h.job(Priority::Background, 1), h.clock.now());
  h.s.submit(h.job(Priority::Command, 2), h.clock.now());
  h.s.submit(h.job(Priority::Completion, 3), h.clock.now());
  h.s.submit(h.job(Priority::Command, 4), h.clock.now());
  h.s.submit(h.job(Priority::Emergency, 5, modbus::WriteCoilRequest{0x1B, modbus::kCoilOn}),
             h.clock.now());
  std::vector<int> order;
  while (auto d = h.step()) order.push_back(d->frame.id);
  EXPECT_EQ(order, (std::vector<int>{5, 2, 4, 3, 1}));
  EXPECT_EQ(h.results.size(), 5u);
}

TEST(Scheduler, OneJobOnTheWireAtATime) {
  Harness h;
  h.s.submit(h.job(Priority::Command, 1), h.clock.now());
  h.s.submit(h.job(Priority::Command, 2), h.clock.now());
  ASSERT_TRUE(h.s.next(h.clock.now()));
  EXPECT_FALSE(h.s.next(h.clock.now()));  // until the first one is done
}

TEST(Scheduler, TelemetryIsRoundRobinAtTheConfiguredRate) {
  SchedulerConfig c;
  c.controls_period = 1h;  // only flags and state here
  for (uint8_t id : {1, 2, 3}) c.axes.push_back({id, 100ms});
  Harness h(c);
  const auto sent = h.run_for(10s);
  std::map<int, int> per_id;
  for (const auto& d : sent) {
    if (d.priority == Priority::Telemetry) ++per_id[d.frame.id];
  }
  // 10 Hz × 10 s × (flags + state) each, ± one pass; the first controls read once.
  for (int id : {1, 2, 3}) EXPECT_NEAR(per_id[id], 200, 4) << id;
}

TEST(Scheduler, TelemetryThatCannotKeepUpStaysFair) {
  SchedulerConfig c;
  c.controls_period = 1h;
  for (uint8_t id = 1; id <= 4; ++id) c.axes.push_back({id, 10ms});  // far beyond the line
  Harness h(c);
  const auto sent = h.run_for(8s);
  std::map<int, int> per_id;
  for (const auto& d : sent) per_id[d.frame.id] += d.priority == Priority::Telemetry;
  const auto [lo, hi] = std::minmax_element(per_id.begin(), per_id.end(),
                                            [](auto& a, auto& b) { return a.second < b.second; });
  EXPECT_LE(hi->second - lo->second, 4);
  EXPECT_GT(lo->second, 150);
}

TEST(Scheduler, CommandsGoBetweenTelemetryReads) {
  SchedulerConfig c;
  c.axes.push_back({1, 10ms});
  Harness h(c);
  h.run_for(100ms);
  h.s.submit(h.job(Priority::Command, 1, modbus::WriteCoilRequest{0x19, modbus::kCoilOn}),
             h.clock.now());
  auto d = h.step();
  ASSERT_TRUE(d);
  EXPECT_EQ(d->priority, Priority::Command);
}

// Three clients that always have a command queued (SCADA polling uncached
// registers back to back) would otherwise fill the line for good; and a move
// that polls for its end back to back would take the line from telemetry.
// Runs 4 s of such a line (10 ms per exchange) and counts what each kind
// got from 2 s on: after the first lag and the alarm histories (background,
// aged at 1 s).
struct FullLine {
  std::map<Priority, int> sent;
  Duration first_poll{};
};
FullLine fill_the_line(bool with_a_move) {
  SchedulerConfig c;
  c.controls_period = 1h;
  c.axes.push_back({1, 100ms});
  c.axes.push_back({2, 100ms});
  Harness h(c);
  std::size_t commands = 0;
  bool polling = false;
  // The clients and the move: each resubmits as soon as its answer is in.
  const auto keep_queued = [&] {
    for (; commands < h.results.size() + 3; ++commands) {
      h.s.submit(h.job(Priority::Command, 3), h.clock.now());
    }
    if (polling || !with_a_move) return;
    Job poll = h.job(Priority::Completion, 4);
    poll.done = [&](const JobResult&) { polling = false; };
    h.s.submit(std::move(poll), h.clock.now());
    polling = true;
  };
  FullLine out;
  const TimePoint t0 = h.clock.now();
  while (h.clock.now() < t0 + 4s) {
    keep_queued();
    const auto d = h.step();
    if (!d) break;
    if (d->priority == Priority::Completion && out.first_poll == Duration{}) {
      out.first_poll = h.clock.now() - t0;
    }
    if (h.clock.now() > t0 + 2s) ++out.sent[d->priority];
  }
  return out;
}

TEST(Scheduler, CommandsThatFillTheLineLeaveTelemetryItsRate) {
  auto [sent, first_poll] = fill_the_line(false);
  // Telemetry keeps its rate, 100 ms late: 2 axes × 10 Hz × (flags + state) × 2 s, ± one pass.
  EXPECT_NEAR(sent[Priority::Telemetry], 2 * 10 * 2 * 2, 2);
  // The clients have the rest: 200 exchanges of 10 ms in all.
  EXPECT_EQ(sent[Priority::Command] + sent[Priority::Telemetry], 200);
}

TEST(Scheduler, AFullLineIsSharedByClientsAMoveAndTelemetry) {
  auto [sent, first_poll] = fill_the_line(true);
  // The move's first completion poll waited its 100 ms, then had its turn.
  EXPECT_GT(first_poll, Duration{});
  EXPECT_LE(first_poll, 100ms + 3 * 10ms);
  // Then clients, the move and telemetry take turns: a third each.
  for (Priority p : {Priority::Command, Priority::Completion, Priority::Telemetry}) {
    EXPECT_GE(sent[p], 200 / 3 - 2) << static_cast<int>(p);
  }
  EXPECT_EQ(sent[Priority::Command] + sent[Priority::Completion] + sent[Priority::Telemetry], 200);
}

TEST(Scheduler, AShortBurstOfCommandsStillGoesFirst) {
  SchedulerConfig c;
  c.controls_period = 1h;
  c.axes.push_back({1, 100ms});
  Harness h(c);
  h.run_for(150ms);       // the first pass is done; the next is due at 200 ms
  h.clock.advance(60ms);  // now it is 10 ms late
  for (int i = 0; i < 5; ++i) h.s.submit(h.job(Priority::Command, 2), h.clock.now());
  std::vector<Priority> order;
  for (int i = 0; i < 7; ++i) order.push_back(h.step()->priority);
  // 5 × 10 ms stays under poll_max_wait: the commands go first, in one run.
  const std::vector<Priority> expected{Priority::Command,  Priority::Command, Priority::Command,
                                       Priority::Command,  Priority::Command, Priority::Telemetry,
                                       Priority::Telemetry};
  EXPECT_EQ(order, expected);
}

TEST(Scheduler, ADeadControllerIsBackedOffAndProbed) {
  SchedulerConfig c;
  c.offline_after = 3;
  c.probe_interval = 2s;
  c.controls_period = 1h;
  c.axes = {{1, 100ms}, {9, 100ms}};
  Harness h(c);
  h.run_for(2s, {9});
  EXPECT_TRUE(h.s.health(9).offline);
  EXPECT_FALSE(h.s.health(1).offline);
  // A client asking for it gets an answer at once.
  h.s.submit(h.job(Priority::Command, 9), h.clock.now());
  ASSERT_EQ(h.results.size(), 0u);
  for (auto& x : h.s.take_completions()) x.done(x.result);
  ASSERT_EQ(h.results.size(), 1u);
  EXPECT_EQ(h.results[0].failure, Failure::Offline);
  EXPECT_THAT(h.results[0].error, HasSubstr("controller ID 9 is not answering"));
  // Over 20 s it costs one probe per interval.
  const auto sent = h.run_for(20s, {9});
  int probes = 0;
  for (const auto& d : sent) probes += d.frame.id == 9;
  EXPECT_GE(probes, 9);
  EXPECT_LE(probes, 11);
  // It comes back: online at the next probe.
  h.run_for(2100ms);
  EXPECT_FALSE(h.s.health(9).offline);
}

TEST(Scheduler, QueuedJobsForADeviceThatGoesOfflineFailAtOnce) {
  SchedulerConfig c;
  c.offline_after = 1;
  Harness h(c);
  h.s.submit(h.job(Priority::Command, 9), h.clock.now());
  h.s.submit(h.job(Priority::Command, 9), h.clock.now());
  h.s.submit(h.job(Priority::Command, 2), h.clock.now());
  h.step({9});
  ASSERT_EQ(h.results.size(), 2u);
  EXPECT_EQ(h.results[0].failure, Failure::NoAnswer);
  EXPECT_EQ(h.results[1].failure, Failure::Offline);
  h.step({9});
  EXPECT_EQ(h.results.back().failure, Failure::None);  // ID 2 still served
}

TEST(Scheduler, ReadsRetryOnALineFaultAndStartsDoNot) {
  Harness h;
  Job read = h.job(Priority::Command, 5);
  read.attempts = 3;
  h.s.submit(std::move(read), h.clock.now());
  h.step({5});
  h.step({5});
  EXPECT_TRUE(h.results.empty());
  h.step();  // answered the third time
  ASSERT_EQ(h.results.size(), 1u);
  EXPECT_EQ(h.results[0].failure, Failure::None);
  h.s.submit(h.job(Priority::Command, 6,
                   modbus::WriteRegistersRequest::of(0x9100, std::vector<uint16_t>{0x0100})),
             h.clock.now());
  h.step({6});
  EXPECT_EQ(h.results.back().failure, Failure::NoAnswer);
}

TEST(Scheduler, StateReadsAreServedFromAFreshCacheAndNeverAfterAWrite) {
  SchedulerConfig c;
  c.axes = {{1, 100ms}};
  Harness h(c);
  h.run_for(50ms);  // the first telemetry pass
  Job cached = h.job(Priority::Command, 1);
  cached.max_cache_age = 200ms;
  h.s.submit(std::move(cached), h.clock.now());
  for (auto& x : h.s.take_completions()) x.done(x.result);
  ASSERT_EQ(h.results.size(), 1u);
  EXPECT_TRUE(h.results[0].from_cache);
  EXPECT_EQ(std::get<modbus::ReadRegistersResponse>(h.results[0].reply->pdu).values[2], 102);
  // A part of the block: D9002 alone; X48–X4F (SVRE is X49).
  Job part = h.job(Priority::Command, 1, ReadRegistersRequest{0x9002, 1});
  part.max_cache_age = 200ms;
  h.s.submit(std::move(part), h.clock.now());
  Job bits =
      h.job(Priority::Command, 1, ReadBitsRequest{modbus::FunctionCode::ReadInputs, 0x48, 8});
  bits.max_cache_age = 200ms;
  h.s.submit(std::move(bits), h.clock.now());
  for (auto& x : h.s.take_completions()) x.done(x.result);
  ASSERT_EQ(h.results.size(), 3u);
  EXPECT_EQ(std::get<modbus::ReadRegistersResponse>(h.results[1].reply->pdu).values,
            std::vector<uint16_t>{102});
  EXPECT_EQ(std::get<modbus::ReadBitsResponse>(h.results[2].reply->pdu).packed,
            modbus::Bytes{0x02});
  // After a write to ID 1, the same read goes to the line.
  h.s.submit(h.job(Priority::Command, 1, modbus::WriteCoilRequest{0x19, modbus::kCoilOn}),
             h.clock.now());
  h.step();
  Job after = h.job(Priority::Command, 1);
  after.max_cache_age = 200ms;
  h.s.submit(std::move(after), h.clock.now());
  for (auto& x : h.s.take_completions()) x.done(x.result);
  EXPECT_EQ(h.results.size(), 4u);  // the write only: the read is queued
  EXPECT_EQ(h.s.queue_depth()[index(Priority::Command)], 1u);
}

TEST(Scheduler, ClientsThatMissTheCacheTogetherCostTheLineOneRead) {
  Harness h;  // no telemetry: the cache is empty
  for (int i = 0; i < 50; ++i) {
    Job j = h.job(Priority::Command, 1);
    j.max_cache_age = 200ms;
    h.s.submit(std::move(j), h.clock.now());
  }
  // A write queued behind them must still see the line, and the reads after it too.
  h.s.submit(h.job(Priority::Command, 1, modbus::WriteCoilRequest{0x19, modbus::kCoilOn}),
             h.clock.now());
  Job after = h.job(Priority::Command, 1);
  after.max_cache_age = 200ms;
  h.s.submit(std::move(after), h.clock.now());
  std::vector<Dispatch> sent;
  while (auto d = h.step()) sent.push_back(*d);
  for (auto& x : h.s.take_completions()) x.done(x.result);
  ASSERT_EQ(sent.size(), 3u);  // the first read, the write, the read after the write
  EXPECT_TRUE(std::holds_alternative<ReadRegistersRequest>(sent[0].frame.pdu));
  EXPECT_TRUE(std::holds_alternative<modbus::WriteCoilRequest>(sent[1].frame.pdu));
  EXPECT_TRUE(std::holds_alternative<ReadRegistersRequest>(sent[2].frame.pdu));
  ASSERT_EQ(h.results.size(), 52u);
  int from_cache = 0;
  for (const auto& r : h.results) from_cache += r.from_cache;
  EXPECT_EQ(from_cache, 49);  // every read but the first and the one after the write
  EXPECT_EQ(h.s.stats(h.clock.now()).cache_hits, 49u);
}

TEST(Scheduler, CancelledJobsNeverReachTheLine) {
  Harness h;
  const JobId a = h.s.submit(h.job(Priority::Command, 1), h.clock.now());
  EXPECT_TRUE(h.s.cancel(a, h.clock.now()));
  for (auto& x : h.s.take_completions()) x.done(x.result);
  ASSERT_EQ(h.results.size(), 1u);
  EXPECT_EQ(h.results[0].failure, Failure::Cancelled);
  EXPECT_FALSE(h.s.next(h.clock.now()));
}

TEST(Scheduler, ShutdownAnswersEveryQueuedJob) {
  Harness h;
  h.s.submit(h.job(Priority::Command, 1), h.clock.now());
  auto in_flight = h.s.next(h.clock.now());
  h.s.submit(h.job(Priority::Command, 2), h.clock.now());
  h.s.submit(h.job(Priority::Background, 3), h.clock.now());
  h.s.shut_down(h.clock.now());
  h.s.completed(answer(*in_flight), h.clock.now(), h.clock.now());  // the one on the wire ends
  h.s.submit(h.job(Priority::Command, 4), h.clock.now());
  for (auto& x : h.s.take_completions()) x.done(x.result);
  ASSERT_EQ(h.results.size(), 4u);
  int shut = 0, answered = 0;
  for (const auto& r : h.results) {
    shut += r.failure == Failure::ShuttingDown;
    answered += r.failure == Failure::None;
  }
  EXPECT_EQ(shut, 3);
  EXPECT_EQ(answered, 1);
}

TEST(Scheduler, APortThatGoesAwayTakesTheLineDownUntilItIsBack) {
  Harness h;
  h.s.submit(h.job(Priority::Command, 1), h.clock.now());
  h.s.submit(h.job(Priority::Command, 2), h.clock.now());
  auto d = h.s.next(h.clock.now());
  h.s.failed(TransportError(TransportErrorKind::Port, "/dev/ttyUSB0 went away"), h.clock.now(),
             h.clock.now());
  EXPECT_TRUE(h.s.is_line_down());
  h.s.submit(h.job(Priority::Command, 3), h.clock.now());
  for (auto& x : h.s.take_completions()) x.done(x.result);
  ASSERT_EQ(h.results.size(), 3u);
  for (const auto& r : h.results) EXPECT_EQ(r.failure, Failure::LineDown);
  h.s.line_up(h.clock.now());
  h.s.submit(h.job(Priority::Command, 4), h.clock.now());
  EXPECT_TRUE(h.step());
}

TEST(Scheduler, UtilisationIsTheShareOfTheLineLimitUsed) {
  SchedulerConfig c;
  c.timing.baud = 38400;
  Harness h(c);
  // The limit of a compliant master: the exchange, then Ts of silence.
  const Duration limit = c.timing.transaction_limit(8, 19) + c.timing.silent_interval();
  for (int i = 0; i < 100; ++i) {
    h.s.submit(h.job(Priority::Command, 1), h.clock.now());
    auto d = h.s.next(h.clock.now());
    const TimePoint start = h.clock.now();
    h.clock.advance(limit);
    h.s.completed(answer(*d), start, h.clock.now());
  }
  const auto st = h.s.stats(h.clock.now());
  EXPECT_NEAR(st.utilisation, 1.0, 0.01);
  EXPECT_NEAR(st.transactions_per_s, 1.0 / to_seconds(limit), 1.0);
  EXPECT_EQ(st.devices.at(1).answers, 100u);
}

// The limit of one exchange of a compliant master (the utilisation's unit):
// an 8-byte query, the reply, and the silent interval before the next query.
Duration exchange_limit(const modbus::LineTiming& t, std::size_t reply_bytes) {
  return t.transaction_limit(8, reply_bytes) + t.silent_interval();
}

TEST(Scheduler, TelemetryDemandIsTheShareOfTheLineItsRatesNeed) {
  SchedulerConfig c;
  c.timing.baud = 38400;
  for (uint8_t id = 1; id <= 4; ++id) c.axes.push_back({id, 100ms});
  c.axes.push_back({5, Duration{}});  // no telemetry: costs nothing
  // Each axis every 100 ms: flags (FC02 ×16, a 7-byte reply) and state (FC03
  // ×7, 19 bytes); every 500 ms its controls (FC01 ×33, 10 bytes).
  const auto& t = c.timing;
  const double per_axis = to_seconds(exchange_limit(t, 7) + exchange_limit(t, 19)) * 10 +
                          to_seconds(exchange_limit(t, 10)) * 2;
  EXPECT_NEAR(telemetry_demand(c), 4 * per_axis, 1e-9);
  EXPECT_GT(telemetry_demand(c), 1.4) << "4 axes at 10 Hz overfill a 38400 line";
  c.axes.resize(1);
  EXPECT_LT(telemetry_demand(c), 0.4);
}

// What the start-up message promises when the rates overfill the line: each
// axis refreshes at about its rate / demand, and all alike.
TEST(Scheduler, AnOverfilledLineRefreshesEachAxisAtItsRateOverTheDemand) {
  SchedulerConfig c;
  c.timing.baud = 38400;
  for (uint8_t id = 1; id <= 4; ++id) c.axes.push_back({id, 100ms});
  const double demand = telemetry_demand(c);
  VirtualClock clock{TimePoint{} + 1s};
  Scheduler s(c, clock.now());
  std::map<uint8_t, int> flag_reads;
  const TimePoint end = clock.now() + 20s;
  while (clock.now() < end) {
    const auto d = s.next(clock.now());
    ASSERT_TRUE(d) << "an overfilled line is never idle";
    const auto* bits = std::get_if<ReadBitsRequest>(&d->frame.pdu);
    const std::size_t reply = bits ? (bits->count + 7u) / 8u + 5u : 19u;
    const TimePoint start = clock.now();
    clock.advance(exchange_limit(c.timing, reply));
    s.completed(answer(*d), start, clock.now());
    if (bits && bits->function == modbus::FunctionCode::ReadInputs) ++flag_reads[d->frame.id];
  }
  for (uint8_t id = 1; id <= 4; ++id) {
    EXPECT_NEAR(flag_reads[id] / 20.0, 10.0 / demand, 0.05 * 10.0 / demand) << int(id);
  }
}

}  // namespace
}  // namespace lec6::serve
