#include "lec6/client/client.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>

#include "lec6/client/rtu_master.hpp"
#include "lec6/modbus/timing.hpp"
#include "sim_fixture.hpp"

namespace lec6::client {
namespace {

using lec::Coil;
using ::testing::HasSubstr;
using testing::SimFixture;

lec::StepData step_150mm() {
  return {lec::MovementMode::Absolute, 500, 15000, 5000, 5000, 0, 0, 20, 100, 0, 0, 100};
}

TEST(Client, ManualOperationExamplesOneToFour) {
  SimFixture f;
  f.prepare();
  auto flags = f.client->read_flags();
  EXPECT_EQ(flags.bits, 0x0E00) << flags.describe();  // SVRE SETON INP, as the manual's reply

  // Example 2: edit step 1; example 1: run it; example 3: read the position.
  f.client->write_step(1, step_150mm());
  auto r = f.axis->run_step(1, f.axis->deadline_in(std::chrono::seconds(10)));
  EXPECT_TRUE(r.in_position);
  EXPECT_EQ(f.client->read_state().position_001mm, 15000);
  EXPECT_EQ(f.client->read_flags().out(), 1);

  // Example 4: direct operation to 300.00 mm.
  DirectMove m;
  m.position_001mm = 30000;
  m.speed_mm_s = 500;
  m.acceleration_mm_s2 = 5000;
  m.deceleration_mm_s2 = 5000;
  m.in_position_001mm = 100;
  r = f.axis->move(m, f.axis->deadline_in(std::chrono::seconds(10)));
  EXPECT_TRUE(r.in_position);
  EXPECT_EQ(r.state.position_001mm, 30000);
  EXPECT_FALSE(r.flags.busy());
}

TEST(Client, ReadStateTakesExactlyTheWireLimitInRealTiming) {
  for (uint32_t baud : {38400u, 115200u}) {
    sim::LineConfig line;
    line.line.baud = baud;
    SimFixture f(line);
    f.client->read_state();
    const modbus::LineTiming t{baud};
    // query 8 bytes, reply 5 + 14 bytes: the digest §1 limit, to the nanosecond.
    EXPECT_NEAR(to_ms(f.client->last_round_trip()), to_ms(t.transaction_limit(8, 19)), 0.001)
        << baud;
  }
}

TEST(Client, ExceptionRepliesAreTypedAndExplained) {
  SimFixture f;  // power-on: parallel input mode
  try {
    f.client->write_coil(Coil::SVON, true);
    FAIL() << "expected exception 02";
  } catch (const ControllerException& e) {
    EXPECT_EQ(e.code(), modbus::ExceptionCode::IllegalAddress);
    EXPECT_THAT(e.what(), HasSubstr("lec serial on"));
    EXPECT_THAT(e.what(), HasSubstr("Y19 SVON"));
  }
  EXPECT_EQ(f.client->stats().exceptions, 1u);
  EXPECT_EQ(f.client->stats().retries, 0u);  // an answer is an answer: not retried
}

TEST(Client, RequestsOutsideTheMapAreRefusedBeforeSending) {
  SimFixture f;
  EXPECT_THROW(f.client->read_registers(0x5000, 1), InvalidRequest);
  EXPECT_THROW(f.client->read_registers(0x9000, 126), InvalidRequest);
  EXPECT_TRUE(f.sent.empty());
  EXPECT_EQ(f.bus.stats().frames, 0u);
  // A step with a bad value is refused before anything is written.
  auto bad = step_150mm();
  bad.trigger_level_pct = 80;
  bad.pushing_force_pct = 50;
  try {
    f.client->write_step(3, bad);
    FAIL();
  } catch (const InvalidRequest& e) {
    EXPECT_STREQ(e.what(), "step 3: trigger level 80 % exceeds pushing force 50 %");
  }
  EXPECT_TRUE(f.sent.empty());
}

TEST(Client, SilentIdTimesOutAfterRetriesWithinTheDeadline) {
  SimFixture f;
  f.client->set_id(7);
  const TimePoint start = f.clock.now();
  try {
    f.client->read_state();
    FAIL();
  } catch (const TransportError& e) {
    EXPECT_EQ(e.kind(), TransportErrorKind::Timeout);
    EXPECT_THAT(e.what(), HasSubstr("ID 7"));
  }
  EXPECT_EQ(f.client->stats().retries, 2u);
  EXPECT_EQ(f.sent.size(), 3u);
  const modbus::LineTiming t;
  const Duration window = t.response_time(19) + std::chrono::milliseconds(50);
  const Duration per_try = t.wire_time(8) + window;
  // Before each retry the line stays quiet for a reply window (late replies)
  // and a drawn pause of at most 64 character times (two masters apart).
  EXPECT_LE(f.clock.now() - start, 3 * (per_try + t.silent_interval()) + 2 * window +
                                       2 * t.wire_time(RtuMaster::kBackoffChars) +
                                       std::chrono::milliseconds(1));
}

// The gaps between the queries a Client sends to ID 7 (nobody answers) on a
// master of its own whose drawn pauses are seeded `seed`; `calls` makes them.
template <typename Calls>
std::vector<Duration> gaps_to_a_silent_id(uint32_t seed, int retries, Calls calls) {
  SimFixture f;
  std::vector<TimePoint> sends;
  RtuOptions ro;
  ro.backoff_seed = seed;
  ro.trace = [&](const TraceEvent& e) {
    if (e.outgoing) sends.push_back(e.at);
  };
  RtuMaster master(*f.link, ro);
  ClientOptions o;
  o.retries = retries;
  o.id = 7;
  Client c(master, o);
  calls(c);
  std::vector<Duration> gaps;
  for (std::size_t i = 1; i < sends.size(); ++i) gaps.push_back(sends[i] - sends[i - 1]);
  return gaps;
}

// Two masters on one line whose frames collided time out together; resending
// after the same fixed hold they would collide on every attempt (seen in
// motion_truth_test: 11 attempts lost). After a failure each master waits the
// reply window and a drawn pause of 0 to 64 character times: the gaps between
// attempts vary, stay bounded, and two masters draw differently.
TEST(Client, ResendsWaitADrawnPauseSoTwoMastersDoNotCollideInStep) {
  const auto read = [](Client& c) { EXPECT_THROW(c.read_state(), TransportError); };
  const auto a = gaps_to_a_silent_id(1, 8, read);
  const auto b = gaps_to_a_silent_id(2, 8, read);
  ASSERT_EQ(a.size(), 8u);
  ASSERT_EQ(b.size(), 8u);
  const modbus::LineTiming t;
  const Duration fixed =
      std::min(*std::min_element(a.begin(), a.end()), *std::min_element(b.begin(), b.end()));
  int differ = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_LE(a[i] - fixed, t.wire_time(RtuMaster::kBackoffChars)) << i;
    EXPECT_LE(b[i] - fixed, t.wire_time(RtuMaster::kBackoffChars)) << i;
    if (std::chrono::abs(a[i] - b[i]) > t.wire_time(2)) ++differ;
  }
  EXPECT_GT(*std::max_element(a.begin(), a.end()) - fixed, t.wire_time(8));  // drawn, not fixed
  EXPECT_GE(differ, 6) << "two masters resending in step would collide again";
}

// A stop after a failure waits neither the drawn pause nor, to another ID,
// the late-reply hold: only Ts of silence after the failed query's window
// (behind a dead neighbour a stop must not wait a second window). To the ID
// whose reply was lost it waits the hold: a late echo of an earlier write to
// the same coil could pass for the stop's reply (a reviewer's finding).
TEST(Client, AStopAfterAFailureDoesNotWaitTheDrawnPause) {
  const modbus::LineTiming t;
  const Duration window = t.response_time(19) + std::chrono::milliseconds(50);
  const modbus::Request reset_on =
      modbus::WriteCoilRequest{lec::address(lec::Coil::RESET), modbus::kCoilOn};
  std::vector<Duration> other, same;
  for (uint32_t seed = 1; seed <= 8; ++seed) {
    const auto g = gaps_to_a_silent_id(seed, 0, [&](Client& c) {
      EXPECT_THROW(c.read_state(), TransportError);  // ID 7: nobody answers
      // ID 1 answers (exception 02: parallel mode; an answer all the same)
      EXPECT_THROW(c.transact(reset_on, Retry::Safe, 1), ControllerException);
    });
    ASSERT_EQ(g.size(), 1u);
    other.push_back(g[0]);
    const auto h = gaps_to_a_silent_id(seed, 0, [](Client& c) {
      EXPECT_THROW(c.read_state(), TransportError);
      EXPECT_THROW(c.write_coil(lec::Coil::RESET, true), TransportError);  // ID 7 again
    });
    ASSERT_EQ(h.size(), 1u);
    same.push_back(h[0]);
  }
  for (const Duration g : other) EXPECT_EQ(g, other.front());
  for (const Duration g : same) EXPECT_EQ(g, same.front());
  EXPECT_LE(other.front(),
            t.wire_time(8) + window + t.silent_interval() + std::chrono::milliseconds(1));
  EXPECT_GE(same.front(), t.wire_time(8) + 2 * window);
}

TEST(Client, CorruptedRepliesAreNeverAcceptedAndClassifiedAsCrc) {
  SimFixture f;
  sim::FaultConfig faults;
  faults.corrupt = 1.0;
  f.bus.set_faults(faults);
  try {
    f.client->read_state();
    FAIL();
  } catch (const TransportError& e) {
    EXPECT_EQ(e.kind(), TransportErrorKind::Crc);
    EXPECT_THAT(e.what(), HasSubstr("baud"));
  }
}

TEST(Client, GarbageBeforeTheReplyIsSkipped) {
  SimFixture f;
  sim::FaultConfig faults;
  faults.garbage = 1.0;
  f.bus.set_faults(faults);
  for (int i = 0; i < 50; ++i) EXPECT_EQ(f.client->echo(static_cast<uint16_t>(i)), i);
}

TEST(Client, RetriesRecoverIdempotentReadsFromDroppedReplies) {
  SimFixture f;
  sim::FaultConfig faults;
  faults.drop = 0.3;
  faults.seed = 42;
  f.bus.set_faults(faults);
  int ok = 0;
  for (int i = 0; i < 100; ++i) {
    try {
      EXPECT_EQ(f.client->echo(static_cast<uint16_t>(i)), i);
      ++ok;
    } catch (const TransportError& e) {
      EXPECT_EQ(e.kind(), TransportErrorKind::Timeout);
    }
  }
  EXPECT_GT(f.client->stats().retries, 10u);
  EXPECT_GE(ok, 95);  // 0.3³ of the calls may fail all three tries
}

TEST(Client, LostReplyToAnIncStartDoesNotMoveTwice) {
  SimFixture f;
  f.prepare();
  DirectMove to100;
  to100.position_001mm = 10000;
  f.axis->move(to100, f.axis->deadline_in(std::chrono::seconds(10)));

  // Drop exactly the reply to the D9100 start; the controller still starts.
  f.on_trace = [&](const TraceEvent& e) {
    if (!e.outgoing) return;
    const bool start =
        e.bytes.size() > 3 && e.bytes[1] == 0x10 && e.bytes[2] == 0x91 && e.bytes[3] == 0x00;
    sim::FaultConfig faults;
    faults.drop = start ? 1.0 : 0.0;
    f.bus.set_faults(faults);
  };
  DirectMove plus50;
  plus50.position_001mm = 5000;
  plus50.relative = true;
  auto r = f.axis->move(plus50, f.axis->deadline_in(std::chrono::seconds(10)));
  EXPECT_EQ(r.state.position_001mm, 15000);  // 100 + 50, not 100 + 2 × 50
  int starts = 0;
  for (const auto& q : f.sent)
    starts += q.size() > 3 && q[1] == 0x10 && q[2] == 0x91 && q[3] == 0x00;
  EXPECT_EQ(starts, 2);  // the two moves' starts: the lost one was not resent
}

TEST(Client, MoveRewritesOnlyTheFieldsThatChanged) {
  SimFixture f;
  f.prepare();
  DirectMove m;
  m.position_001mm = 10000;
  f.axis->move(m, f.axis->deadline_in(std::chrono::seconds(10)));
  f.sent.clear();
  m.position_001mm = 20000;
  f.axis->move(m, f.axis->deadline_in(std::chrono::seconds(10)));
  // The only direct-data write is D9105, the low word of the position (the
  // high word is 0 for both targets).
  int data_writes = 0;
  for (const auto& q : f.sent) {
    if (q[1] == 0x10 && q[2] == 0x91 && q[3] != 0x00) {
      ++data_writes;
      EXPECT_EQ(q[3], 0x05);
      EXPECT_EQ(q[5], 1);
    }
  }
  EXPECT_EQ(data_writes, 1);
}

TEST(Client, BroadcastReachesEveryControllerWithoutReply) {
  SimFixture f({}, {1, 2, 3});
  const TimePoint start = f.clock.now();
  f.client->broadcast(modbus::WriteCoilRequest{lec::address(Coil::SerialMode), modbus::kCoilOn});
  const modbus::LineTiming t;
  EXPECT_GE(f.clock.now() - start, t.response_time(8));  // waited Tx
  for (uint8_t id : {1, 2, 3}) {
    const auto reply = f.client->transact(
        modbus::ReadBitsRequest{modbus::FunctionCode::ReadCoils, 0x30, 1}, Retry::Safe, id);
    EXPECT_TRUE(std::get<modbus::ReadBitsResponse>(reply).bit(0)) << "ID " << int(id);
  }
  EXPECT_THROW(f.client->broadcast(modbus::ReadRegistersRequest{0x9000, 1}), InvalidRequest);
}

TEST(Client, ReadsAllStepsInTenTransactions) {
  SimFixture f;
  f.client->write_step(0, step_150mm());
  auto s = step_150mm();
  s.position_001mm = -2500;
  f.client->write_step(63, s);
  f.sent.clear();
  const auto steps = f.client->read_all_steps();
  EXPECT_EQ(f.sent.size(), 10u);
  EXPECT_EQ(steps[0], step_150mm());
  EXPECT_EQ(steps[63].position_001mm, -2500);
  EXPECT_TRUE(steps[5].is_blank());
}

// The line settings of ClientOptions act only on a Client made on a Link: a
// Client given a Master refuses them rather than drop them unseen.
TEST(Client, OnAMasterRefusesTheLineSettingsItCannotApply) {
  SimFixture f;
  RtuMaster master(*f.link);
  ClientOptions o;
  o.trace = [](const TraceEvent&) {};
  o.timeout_margin = std::chrono::milliseconds(200);
  try {
    Client c(master, o);
    FAIL() << "a trace and a margin that would do nothing were taken";
  } catch (const lec6::InvalidArgument& e) {
    EXPECT_THAT(e.what(), HasSubstr("timeout_margin, trace"));
    EXPECT_THAT(e.what(), HasSubstr("RtuOptions"));
  }
  ClientOptions interrupted;
  interrupted.interrupted = [] { return false; };
  EXPECT_THROW({ Client c(master, interrupted); }, lec6::InvalidArgument);
  Client ok(master, {.id = 1, .retries = 0});  // id and retries act on any master
  EXPECT_FALSE(ok.read_flags().busy());
}

}  // namespace
}  // namespace lec6::client
