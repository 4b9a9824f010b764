// Fault soak: our client against the twin with a noisy line (replies
// corrupted, dropped, preceded by garbage, late), on a virtual clock, for
// thousands of mixed transactions. Every call ends as one of three things,
// counted apart: a correct value (checked against the twin's actual state, its
// Controller queried directly, or the value we wrote), an error refused and
// reported (a classified TransportError: the caller knows it has no value), or
// a wrong value accepted. Only the last must be 0; no call may take longer than
// its configured deadlines allow. A summary table and a line with the three
// counts are printed per run. Over 450 lines: the fault soak and the bad-input
// cases share the twin fixture and the counting.
//
// LEC6_SOAK_TRANSACTIONS sets the number of transactions per run (default
// 10 000); `make soak` runs these tests alone. The client's bad-input tests
// of docs/robustness.md (refused before sending, wrong ID, broadcast misuse)
// are at the end.

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <array>
#include <chrono>
#include <cstdlib>
#include <map>
#include <random>
#include <string>

#include "lec6/client/client.hpp"
#include "lec6/client/errors.hpp"
#include "lec6/client/rtu_master.hpp"
#include "lec6/lec/memory_map.hpp"
#include "lec6/lec/step_data.hpp"
#include "sim_fixture.hpp"

namespace lec6::client {
namespace {

using testing::SimFixture;

int soak_transactions() {
  if (const char* env = std::getenv("LEC6_SOAK_TRANSACTIONS"); env && *env)
    return std::max(1, std::atoi(env));
  return 10000;
}

enum class SoakOp {
  ReadState,
  ReadFlags,
  ReadControls,
  ReadStep,
  ReadName,
  ReadAlarms,
  Echo,
  WriteCoil,
  SelectStep,
  WriteStep,
  VerifyStep,
  WriteOnce,
  ExceptionProbe,
};
constexpr std::size_t kOps = 13;
constexpr std::array<const char*, kOps> kOpNames = {
    "read state D9000x7", "read flags X40x16",    "read coils Y10x33",   "read step D04n0x16",
    "read name D000Ex8",  "read alarms D0380x64", "echo FC08",           "write coil Y16/17/1F",
    "select step FC0F",   "write step (FC10)",    "  verify: read back", "write, no retry",
    "exception probe"};

// FirstTry/AfterRetry: a correct value; Wrong: a wrong value accepted; the
// rest: an error refused and reported.
enum class Result { FirstTry, AfterRetry, Timeout, Crc, Framing, Exception, Other, Wrong };
constexpr std::size_t kResults = 8;

struct Row {
  std::array<uint64_t, kResults> n{};
  uint64_t calls = 0;
  uint64_t correct() const { return n[0] + n[1]; }
  uint64_t refused() const { return calls - correct() - n[7]; }
};

struct Report {
  std::string name;
  std::array<Row, kOps> rows{};
  uint64_t transactions = 0;  // Modbus transactions (retries included)
  uint64_t failed_but_applied = 0;
  Duration longest_call{};
  Duration call_bound{};
  sim::Bus::Stats twin;
  LinkStats link;
  double wall_s = 0;

  uint64_t wrong() const { return count(Result::Wrong); }
  uint64_t correct() const { return count(Result::FirstTry) + count(Result::AfterRetry); }
  uint64_t calls() const {
    uint64_t c = 0;
    for (const auto& row : rows) c += row.calls;
    return c;
  }
  uint64_t refused() const { return calls() - correct() - wrong(); }
  uint64_t count(Result r) const {
    uint64_t c = 0;
    for (const auto& row : rows) c += row.n[static_cast<std::size_t>(r)];
    return c;
  }
  uint64_t idempotent_failures() const {
    uint64_t c = 0;
    for (std::size_t op = 0; op < kOps; ++op) {
      if (op == static_cast<std::size_t>(SoakOp::WriteOnce) ||
          op == static_cast<std::size_t>(SoakOp::ExceptionProbe))
        continue;
      for (auto r : {Result::Timeout, Result::Crc, Result::Framing, Result::Other}) {
        c += rows[op].n[static_cast<std::size_t>(r)];
      }
    }
    return c;
  }
};

std::string row_line(const char* name, const Row& row) {
  return fmt::format("{:<22} {:>6} {:>7} {:>7} {:>7} {:>7} {:>5} {:>7} {:>5} {:>5} {:>6}\n", name,
                     row.calls, row.correct(), row.n[1], row.refused(), row.n[2], row.n[3],
                     row.n[4], row.n[5], row.n[6], row.n[7]);
}

std::string table(const Report& r) {
  std::string out = fmt::format("\n== soak: {} ==\n", r.name);
  out += fmt::format("{:<22} {:>6} {:>7} {:>7} {:>7} {:>7} {:>5} {:>7} {:>5} {:>5} {:>6}\n",
                     "operation", "calls", "correct", "retried", "refused", "timeout", "CRC",
                     "framing", "exc.", "other", "WRONG");
  Row total;
  for (std::size_t op = 0; op < kOps; ++op) {
    const Row& row = r.rows[op];
    if (!row.calls) continue;
    out += row_line(kOpNames[op], row);
    total.calls += row.calls;
    for (std::size_t i = 0; i < kResults; ++i) total.n[i] += row.n[i];
  }
  out += row_line("total", total);
  out += fmt::format(
      "Modbus transactions {} (retries {}); twin: {} replies, {} dropped, {} corrupted, {} with "
      "garbage, {} late\n",
      r.link.transactions, r.link.retries, r.twin.replies, r.twin.faults_dropped,
      r.twin.faults_corrupted, r.twin.faults_garbage, r.twin.faults_delayed);
  out += fmt::format(
      "client saw: {} timeouts, {} CRC, {} framing, {} exceptions, {} bytes discarded\n",
      r.link.timeouts, r.link.crc_errors, r.link.framing_errors, r.link.exceptions,
      r.link.bytes_discarded);
  out += fmt::format("writes reported failed but applied (reply lost): {}\n", r.failed_but_applied);
  out += fmt::format("longest call {:.1f} ms (bound {:.1f} ms), wall time {:.2f} s\n",
                     to_ms(r.longest_call), to_ms(r.call_bound), r.wall_s);
  out += fmt::format(
      "soak [{}]: {} calls: {} correct values, {} errors refused and reported, {} wrong values "
      "accepted\n",
      r.name, r.calls(), r.correct(), r.refused(), r.wrong());
  return out;
}

// A random step record the manual allows (validate() passes).
lec::StepData random_step(std::mt19937_64& rng) {
  lec::StepData s;
  for (const auto& f : lec::step_fields()) {
    int64_t lo = f.min, hi = f.max;
    if (f.is_length) lo = std::max<int64_t>(lo, -100000), hi = std::min<int64_t>(hi, 100000);
    lec::set_field(s, f.field, std::uniform_int_distribution<int64_t>(lo, hi)(rng));
  }
  if (s.trigger_level_pct > s.pushing_force_pct) s.trigger_level_pct = s.pushing_force_pct;
  return s;
}

struct Soak {
  SimFixture f;
  sim::Controller& twin;
  std::mt19937_64 rng;
  Report report;
  int retries = 2;

  explicit Soak(const std::string& name, const sim::FaultConfig& faults, uint64_t seed = 7)
      : twin(*f.bus.find(1)), rng(seed) {
    report.name = name;
    f.prepare();  // serial mode, servo on, homed: at rest from here on
    f.bus.set_faults(faults);
    const auto& line = f.client->timing();
    // One call: up to 1 + retries attempts, each waiting for silence (bytes
    // still arriving, at most a long reply's wire time plus a late reply),
    // sending and waiting Tx + margin for the longest reply.
    const Duration attempt = line.silent_interval() + 2 * line.wire_time(modbus::kMaxAdu) +
                             faults.extra_delay + line.response_time(modbus::kMaxAdu) +
                             f.client->options().timeout_margin;
    report.call_bound = (1 + retries) * attempt;
  }

  template <typename Fn>
  void call(SoakOp op, Fn&& fn) {
    Row& row = report.rows[static_cast<std::size_t>(op)];
    ++row.calls;
    const uint64_t retries_before = f.client->stats().retries;
    const TimePoint start = f.clock.now();
    Result result;
    try {
      if (!fn())
        result = Result::Wrong;
      else
        result =
            f.client->stats().retries == retries_before ? Result::FirstTry : Result::AfterRetry;
    } catch (const TransportError& e) {
      switch (e.kind()) {
        case TransportErrorKind::Timeout:
          result = Result::Timeout;
          break;
        case TransportErrorKind::Crc:
          result = Result::Crc;
          break;
        case TransportErrorKind::Framing:
          result = Result::Framing;
          break;
        default:
          result = Result::Other;
          break;
      }
    } catch (const ControllerException&) {
      result = Result::Exception;
    } catch (const std::exception& e) {
      ADD_FAILURE() << kOpNames[static_cast<std::size_t>(op)]
                    << ": unclassified failure: " << e.what();
      result = Result::Other;
    }
    ++row.n[static_cast<std::size_t>(result)];
    report.longest_call = std::max(report.longest_call, f.clock.now() - start);
  }

  void step_once() {
    Client& c = *f.client;
    const auto now = [&] { return f.clock.now(); };
    const int k = std::uniform_int_distribution<int>(0, 99)(rng);
    if (k < 15) {
      call(SoakOp::ReadState, [&] { return c.read_state() == twin.state(now()); });
    } else if (k < 30) {
      call(SoakOp::ReadFlags, [&] { return c.read_flags() == twin.status(now()); });
    } else if (k < 37) {
      call(SoakOp::ReadControls, [&] {
        const auto got = c.read_controls();
        return got.y10_1f == twin.control().y10_1f && got.serial_mode == twin.control().serial_mode;
      });
    } else if (k < 52) {
      const unsigned n = std::uniform_int_distribution<unsigned>(0, 63)(rng);
      call(SoakOp::ReadStep, [&] { return c.read_step(n) == twin.eeprom().steps[n]; });
    } else if (k < 55) {
      call(SoakOp::ReadName, [&] { return c.read_name() == twin.eeprom().name; });
    } else if (k < 57) {
      call(SoakOp::ReadAlarms, [&] { return c.read_alarms() == twin.eeprom().alarms; });
    } else if (k < 64) {
      const auto data = static_cast<uint16_t>(rng());
      call(SoakOp::Echo, [&] { return c.echo(data) == data; });
    } else if (k < 72) {
      static constexpr uint16_t kInert[] = {0x16, 0x17,
                                            0x1F};  // "cannot be used": accepted, no effect
      const uint16_t coil = kInert[rng() % 3];
      const bool on = rng() & 1;
      call(SoakOp::WriteCoil, [&] {
        c.write_coil(static_cast<lec::Coil>(coil), on);
        return ((twin.control().y10_1f >> (coil - 0x10)) & 1U) == (on ? 1U : 0U);
      });
    } else if (k < 78) {
      const unsigned n = std::uniform_int_distribution<unsigned>(0, 63)(rng);
      call(SoakOp::SelectStep, [&] {
        c.select_step(n);
        return twin.control().selected_step() == n;
      });
    } else if (k < 92) {
      // A step write with verify: the machine's program in EEPROM.
      const unsigned n = std::uniform_int_distribution<unsigned>(0, 63)(rng);
      const lec::StepData want = (rng() % 8 == 0) ? lec::StepData{} : random_step(rng);
      bool written = false;
      call(SoakOp::WriteStep, [&] {
        c.write_step(n, want);
        written = true;
        return twin.eeprom().steps[n] == want;
      });
      // Faults only touch replies: the write arrived even when its reply did not.
      if (!written && twin.eeprom().steps[n] == want) ++report.failed_but_applied;
      call(SoakOp::VerifyStep, [&] {
        const auto got = c.read_step(n);
        return got == twin.eeprom().steps[n] && (!written || got == want);
      });
    } else if (k < 96) {
      const unsigned n = std::uniform_int_distribution<unsigned>(0, 63)(rng);
      const lec::StepData want = random_step(rng);
      const auto regs = want.to_registers();
      bool written = false;
      call(SoakOp::WriteOnce, [&] {
        c.write_registers(lec::step_address(n), regs, Retry::Never);
        written = true;
        return twin.eeprom().steps[n] == want;
      });
      if (!written && twin.eeprom().steps[n] == want) ++report.failed_but_applied;
    } else {
      // A read outside the map, sent raw: the right answer is exception 02.
      call(SoakOp::ExceptionProbe, [&] {
        const auto reply = c.transact_raw({1, modbus::ReadRegistersRequest{0x2000, 1}});
        const auto* ex = std::get_if<modbus::ExceptionResponse>(&reply.pdu);
        return ex && ex->code == modbus::ExceptionCode::IllegalAddress;
      });
    }
  }

  Report run(int n) {
    const auto wall = std::chrono::steady_clock::now();
    for (int i = 0; i < n; ++i) step_once();
    report.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall).count();
    report.twin = f.bus.stats();
    report.link = f.client->stats();
    return report;
  }
};

// Only wrong values must be 0; errors are fine when refused and reported as
// one of the kinds the line can cause (the twin at rest never answers a valid
// request with an exception: the probes get theirs through transact_raw).
void expect_clean(const Report& r, bool strict_recovery) {
  std::cout << table(r) << std::flush;
  EXPECT_EQ(r.wrong(), 0u) << "wrong values accepted";
  EXPECT_EQ(r.correct() + r.refused() + r.wrong(), r.calls());
  EXPECT_GT(r.correct(), r.calls() / 2) << "most calls must give a correct value";
  EXPECT_EQ(r.count(Result::Other), 0u) << "unclassified failures";
  EXPECT_EQ(r.count(Result::Exception), 0u) << "exception replies to valid requests";
  EXPECT_LE(r.longest_call, r.call_bound) << "a call ran past its deadlines";
  const uint64_t calls = r.calls();
  if (strict_recovery) {
    // Per attempt a few % of replies are lost; three attempts make a lost
    // call rare: at most 1 in 1000 calls may still fail.
    EXPECT_LE(r.idempotent_failures() * 1000, calls)
        << "retries did not recover the idempotent calls";
  }
  EXPECT_GT(r.link.retries, 0u) << "faults injected but no retry happened";
}

sim::FaultConfig faults(double corrupt, double drop, double garbage = 0, double delay = 0,
                        Duration extra = std::chrono::milliseconds(50), uint64_t seed = 1) {
  sim::FaultConfig fc;
  fc.corrupt = corrupt;
  fc.drop = drop;
  fc.garbage = garbage;
  fc.delay = delay;
  fc.extra_delay = extra;
  fc.seed = seed;
  return fc;
}

// The acceptance run of the issue: 2 % of replies corrupted, 1 % dropped.
TEST(Soak, TwoPercentCorruptOnePercentDroppedAcceptsNoWrongValue) {
  Soak s("2% corrupted + 1% dropped", faults(0.02, 0.01));
  const auto r = s.run(soak_transactions());
  expect_clean(r, true);
  EXPECT_GT(r.twin.faults_corrupted, 0u);
  EXPECT_GT(r.twin.faults_dropped, 0u);
}

TEST(Soak, GarbageBeforeRepliesAcceptsNoWrongValue) {
  Soak s("2% corrupted + 1% dropped + 5% garbage before the reply",
         faults(0.02, 0.01, 0.05, 0, {}, 2));
  const auto r = s.run(soak_transactions());
  expect_clean(r, true);
  EXPECT_GT(r.twin.faults_garbage, 0u);
}

TEST(Soak, LateRepliesWithinTheMarginAcceptNoWrongValue) {
  // 30 ms late: inside the 50 ms margin over Tx, so the reply still counts.
  Soak s("2% corrupted + 1% dropped + 10% of replies 30 ms late",
         faults(0.02, 0.01, 0, 0.10, std::chrono::milliseconds(30), 3));
  const auto r = s.run(soak_transactions());
  expect_clean(r, true);
  EXPECT_GT(r.twin.faults_delayed, 0u);
}

TEST(Soak, EverythingAtOnceAcceptsNoWrongValue) {
  Soak s("5% corrupted + 3% dropped + 5% garbage + 5% 40 ms late",
         faults(0.05, 0.03, 0.05, 0.05, std::chrono::milliseconds(40), 4));
  const auto r = s.run(soak_transactions());
  expect_clean(r, false);
}

// Replies later than Tx + margin: the client has timed out and moved on. The
// late reply must not land in a later transaction's window (Modbus RTU cannot
// tell a stale reply from a fresh one of the same shape), so after a failure
// the client waits for a whole reply window of silence before the next query.
TEST(Soak, RepliesLaterThanTheTimeoutAcceptNoWrongValue) {
  Soak s("2% of replies 100 ms late (beyond Tx + 50 ms margin)",
         faults(0, 0, 0, 0.02, std::chrono::milliseconds(100), 5));
  const auto r = s.run(soak_transactions());
  expect_clean(r, false);
}

// Minimal: one reply 100 ms late (beyond Tx + 50 ms), no retries. The read of
// step 1 times out; the late reply to it must not be taken as the answer to
// the next read, of step 2.
TEST(Soak, ALateReplyIsNotTakenForTheNextRequestsReply) {
  SimFixture f;
  f.prepare();
  lec::StepData one{lec::MovementMode::Absolute, 100, 10000, 1000, 1000, 0, 0, 10, 100, 0, 0, 100};
  lec::StepData two = one;
  two.position_001mm = 20000;
  f.client->write_step(1, one);
  f.client->write_step(2, two);
  ClientOptions o;
  o.retries = 0;
  Client c(*f.link, o);
  f.bus.set_faults(faults(0, 0, 0, 1.0, std::chrono::milliseconds(100)));
  EXPECT_THROW(c.read_step(1), TransportError);  // timed out: the reply is on its way, late
  f.bus.set_faults({});
  // The line is clean again: the read must give step 2's record. (An error
  // here would hide the value this test exists to check.)
  lec::StepData got;
  try {
    got = c.read_step(2);
  } catch (const TransportError& e) {
    FAIL() << "reading step 2 on a clean line failed: " << e.what();
  }
  EXPECT_EQ(got, two) << "step 2 read as position " << got.position_001mm << " (step 1's)";
}

// ---- client-side bad inputs (docs/robustness.md) ---------------------------------

TEST(BadInput, OutOfRangeValuesAreRefusedBeforeAnythingIsSent) {
  SimFixture f;
  f.prepare();
  const std::size_t sent = f.sent.size();
  std::mt19937_64 rng(1);
  lec::StepData bad = random_step(rng);
  bad.pushing_force_pct = 50;
  bad.trigger_level_pct = 101;
  EXPECT_THROW(f.client->write_step(3, bad), InvalidRequest);
  EXPECT_THROW(f.client->write_step(64, lec::StepData{}), InvalidRequest);
  EXPECT_THROW(f.client->read_step(64), InvalidRequest);
  EXPECT_THROW(f.client->select_step(64), InvalidRequest);
  EXPECT_THROW(f.client->write_direct(lec::StepData{}), InvalidRequest)
      << "a blank direct operation";
  EXPECT_THROW(f.client->read_registers(0x9000, 0), InvalidRequest);
  EXPECT_THROW(f.client->read_registers(0x9000, 126), InvalidRequest);
  EXPECT_THROW(f.client->read_registers(0x2000, 1), InvalidRequest) << "outside the map";
  EXPECT_THROW(f.client->read_registers(0x07F8, 16), InvalidRequest) << "past the step area";
  const uint16_t one[] = {1};
  EXPECT_THROW(f.client->write_registers(0x9000, one), InvalidRequest) << "read-only state";
  EXPECT_THROW(f.client->transact(modbus::WriteCoilRequest{0x19, 0x1234}), InvalidRequest);
  EXPECT_THROW(f.client->transact(modbus::EchoRequest{1, 0}), InvalidRequest)
      << "echo test code not 0000";
  EXPECT_EQ(f.sent.size(), sent) << "a refused request reached the line";
  try {
    f.client->write_step(3, bad);
  } catch (const InvalidRequest& e) {
    EXPECT_NE(std::string(e.what()).find("trigger"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("step 3"), std::string::npos) << e.what();
  }
}

TEST(BadInput, BroadcastReadsAreRefusedAndBroadcastWritesWaitTx) {
  SimFixture f;
  const std::size_t sent = f.sent.size();
  EXPECT_THROW(f.client->broadcast(modbus::ReadRegistersRequest{0x9000, 7}), InvalidRequest);
  EXPECT_THROW(f.client->broadcast(modbus::EchoRequest{0, 1}), InvalidRequest);
  EXPECT_EQ(f.sent.size(), sent);
  const TimePoint before = f.clock.now();
  f.client->broadcast(modbus::WriteCoilRequest{0x30, modbus::kCoilOn});
  EXPECT_TRUE(f.bus.find(1)->control().serial_mode) << "a broadcast write is executed";
  EXPECT_GE(f.clock.now() - before, f.client->timing().response_time(8))
      << "no wait of Tx after a broadcast";
}

TEST(BadInput, AWrongIdTimesOutWithAClearMessageAndNoHang) {
  SimFixture f;
  f.client->set_id(7);  // nobody there
  const TimePoint start = f.clock.now();
  try {
    f.client->read_state();
    FAIL() << "ID 7 answered";
  } catch (const TransportError& e) {
    EXPECT_EQ(e.kind(), TransportErrorKind::Timeout);
    EXPECT_NE(std::string(e.what()).find("ID 7"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("check the ID"), std::string::npos) << e.what();
  }
  const auto& t = f.client->timing();
  // Three attempts, each: Ts of silence, the query on the wire, Tx + margin;
  // before each retry the line must also stay quiet for a reply window
  // (a late reply must not be taken for the next one), and a drawn pause of
  // at most 64 characters (two masters on one line must not resend together).
  const Duration window = t.response_time(19) + f.client->options().timeout_margin;
  const Duration attempt = t.silent_interval() + t.wire_time(8) + window;
  EXPECT_LE(f.clock.now() - start, 3 * attempt + 2 * window +
                                       2 * t.wire_time(RtuMaster::kBackoffChars) +
                                       to_duration(FractionalMilliseconds(0.01)));
  EXPECT_EQ(f.client->stats().retries, 2u);
}

TEST(BadInput, ExceptionRepliesAreClassifiedAndNotRetried) {
  SimFixture f;  // parallel input mode: SVON is refused with 02
  try {
    f.client->write_coil(lec::Coil::SVON, true);
    FAIL() << "SVON accepted in parallel mode";
  } catch (const ControllerException& e) {
    EXPECT_EQ(e.code(), modbus::ExceptionCode::IllegalAddress);
  }
  EXPECT_EQ(f.client->stats().retries, 0u);
  EXPECT_EQ(f.client->stats().exceptions, 1u);
}

}  // namespace
}  // namespace lec6::client
