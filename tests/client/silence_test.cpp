// The master's wait for a quiet line (manual §8.2) against a twin whose idle
// line is noisy, on the virtual clock: bounded with a clear error, ended at
// once by Ctrl-C, and never in the way of a stop. Also: reads to ID 0.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "lec6/client/interrupt.hpp"
#include "lec6/client/rtu_master.hpp"
#include "sim_fixture.hpp"

namespace lec6::client {
namespace {

using ::testing::HasSubstr;
using testing::SimFixture;

void noise(SimFixture& f, double bytes_per_s) {
  sim::FaultConfig faults;
  faults.noise_rate = bytes_per_s;
  faults.seed = 3;
  f.bus.set_faults(faults);
}

TEST(Silence, ALineThatIsNeverQuietFailsWithinItsBoundAndSaysWhy) {
  SimFixture f;
  noise(f, 1e9);  // a byte every character time: never Ts of silence
  const TimePoint began = f.clock.now();
  try {
    f.client->read_flags();
    FAIL();
  } catch (const TransportError& e) {
    EXPECT_EQ(e.kind(), TransportErrorKind::LineBusy);
    EXPECT_THAT(e.what(), HasSubstr("line never silent"));
    EXPECT_THAT(e.what(), HasSubstr("noise on the line, or another master"));
  }
  const auto& line = f.bus.line().line;
  const Duration bound =
      line.silent_interval() + line.response_time(modbus::kMaxAdu) + std::chrono::milliseconds(50);
  EXPECT_LE(f.clock.now() - began, bound + line.char_time() * 2);
  EXPECT_GE(f.clock.now() - began, bound);
  EXPECT_TRUE(f.sent.empty()) << "nothing may be sent on a line that is not quiet";
  EXPECT_GT(f.client->stats().bytes_discarded, 100u);
}

TEST(Silence, AQuietEnoughLineWorksAndTheNoiseIsCounted) {
  SimFixture f;
  noise(f, 50);
  f.prepare();
  for (int i = 0; i < 300; ++i) f.client->read_state();
  EXPECT_GT(f.bus.stats().noise_bytes, 10u);
  EXPECT_GT(f.client->stats().bytes_discarded, 0u);
}

TEST(Silence, CtrlCEndsTheWaitAtOnceWithNothingSent) {
  SimFixture f;
  noise(f, 1e9);
  const TimePoint began = f.clock.now();
  ClientOptions o;
  o.timeout_margin = std::chrono::seconds(60);  // the silence bound is a minute now
  o.interrupted = [&] { return f.clock.now() - began > std::chrono::milliseconds(30); };
  f.reconnect(o);
  EXPECT_THROW(f.client->read_flags(), Cancelled);
  EXPECT_LT(f.clock.now() - began,
            std::chrono::milliseconds(30) + kInterruptCheck + std::chrono::milliseconds(1));
  EXPECT_TRUE(f.sent.empty());
}

TEST(Silence, CtrlCNeverStopsAStop) {
  SimFixture f;
  f.prepare();
  ClientOptions o;
  o.interrupted = [] { return true; };
  f.reconnect(o);
  f.sent.clear();
  EXPECT_THROW(f.client->read_flags(), Cancelled);
  EXPECT_TRUE(f.sent.empty());
  EXPECT_NO_THROW(f.axis->stop());  // RESET pulse
  EXPECT_NO_THROW(f.client->write_coil(lec::Coil::DRIVE, false));
  EXPECT_THROW(f.client->write_coil(lec::Coil::DRIVE, true), Cancelled);
  EXPECT_EQ(f.sent.size(), 3u);
}

TEST(Silence, IdleUntilListensToTheLine) {
  SimFixture f;
  noise(f, 200);
  const TimePoint until = f.clock.now() + std::chrono::seconds(1);
  f.client->idle_until(until);
  EXPECT_EQ(f.clock.now(), until);
  EXPECT_GT(f.client->stats().bytes_discarded, 100u);
}

// Passes everything to the twin's link and notes the waits that asked to end
// at an exact instant (Link::read_some_exact).
class ExactWaits final : public Link {
 public:
  explicit ExactWaits(Link& inner) : inner_(inner) {}
  void write(std::span<const uint8_t> bytes) override { inner_.write(bytes); }
  std::size_t read_some(std::span<uint8_t> buffer, TimePoint deadline) override {
    return inner_.read_some(buffer, deadline);
  }
  std::size_t read_some_exact(std::span<uint8_t> buffer, TimePoint deadline) override {
    exact.push_back(deadline);
    return inner_.read_some(buffer, deadline);
  }
  void discard_input() override { inner_.discard_input(); }
  const Clock& clock() const override { return inner_.clock(); }
  uint32_t baud() const override { return inner_.baud(); }
  std::string describe() const override { return inner_.describe(); }

  std::vector<TimePoint> exact;

 private:
  Link& inner_;
};

TEST(Silence, TheEndOfTsIsWaitedForExactlyAndTheReplyIsNot) {
  SimFixture f;
  ExactWaits link(*f.link);
  RtuMaster master(link);
  const modbus::RequestFrame read{1, modbus::ReadRegistersRequest{0x9000, 7}};
  master.exchange(read);  // the first query listens for Ts too
  ASSERT_EQ(link.exact.size(), 1u);
  const TimePoint reply_done = f.clock.now();
  master.exchange(read);
  ASSERT_EQ(link.exact.size(), 2u);  // one per query: none while awaiting the reply
  EXPECT_EQ(link.exact[1], reply_done + master.line_timing().silent_interval());
}

// Passes everything to the twin's link; its next `stalls` reads begin
// `stall` late, as on a host that ran something else first.
class LateWakes final : public Link {
 public:
  LateWakes(Link& inner, VirtualClock& clock) : inner_(inner), clock_(clock) {}
  void write(std::span<const uint8_t> bytes) override {
    ++writes;
    inner_.write(bytes);
  }
  std::size_t read_some(std::span<uint8_t> buffer, TimePoint deadline) override {
    if (stalls > 0) --stalls, clock_.advance(stall);
    return inner_.read_some(buffer, deadline);
  }
  void discard_input() override { inner_.discard_input(); }
  const Clock& clock() const override { return inner_.clock(); }
  uint32_t baud() const override { return inner_.baud(); }
  std::string describe() const override { return inner_.describe(); }

  int stalls = 0;
  Duration stall{};
  int writes = 0;

 private:
  Link& inner_;
  VirtualClock& clock_;
};

// CI, stop 40: a master woken 130 ms late found the noise of that time
// (50 bytes/s) and said "line never silent" with nothing sent and no retry.
TEST(Silence, ALateWakeIsNotTakenForABusyLine) {
  SimFixture f;
  noise(f, 50);
  LateWakes link(*f.link, f.clock);
  RtuMaster master(link);
  const modbus::RequestFrame read{1, modbus::ReadRegistersRequest{0x9000, 7}};
  master.exchange(read);
  for (int i = 0; i < 20; ++i) {
    link.stalls = 1;
    // Longer than four windows (about 540 ms at 38400): the bytes of them all
    // at once, and still a whole window to watch after the wake.
    link.stall = std::chrono::milliseconds(700);
    EXPECT_NO_THROW(master.exchange(read)) << "exchange " << i;
  }
  EXPECT_GT(master.stats().bytes_discarded, 20u) << "the stalls must have found noise";
}

TEST(Silence, ABusyLineStillFailsWithinABoundWhenEveryLookIsLate) {
  SimFixture f;
  noise(f, 1e9);
  LateWakes link(*f.link, f.clock);
  link.stalls = 1'000'000;
  link.stall = std::chrono::milliseconds(15);
  RtuMaster master(link);
  const TimePoint began = f.clock.now();
  const modbus::RequestFrame read{1, modbus::ReadRegistersRequest{0x9000, 7}};
  EXPECT_THROW(master.exchange(read), TransportError);
  const auto& line = f.bus.line().line;
  const Duration window =
      line.silent_interval() + line.response_time(modbus::kMaxAdu) + std::chrono::milliseconds(50);
  EXPECT_GT(f.clock.now() - began, window) << "late looks start the bound again";
  EXPECT_LE(f.clock.now() - began, 4 * window + 4 * link.stall) << "but a bounded number of times";
  EXPECT_EQ(link.writes, 0) << "nothing may be sent on a line that is not quiet";
}

TEST(Broadcast, AReadToIdZeroIsRefusedUnsent) {
  SimFixture f;
  f.client->set_id(0);
  try {
    f.client->read_state();
    FAIL();
  } catch (const InvalidRequest& e) {
    EXPECT_THAT(e.what(), HasSubstr("ID 0 is broadcast"));
  }
  EXPECT_TRUE(f.sent.empty());
  EXPECT_NO_THROW(f.client->write_coil(lec::Coil::SerialMode, true));  // writes may be broadcast
  f.client->set_id(1);
  EXPECT_TRUE(f.client->read_controls().serial_mode);
}

}  // namespace
}  // namespace lec6::client
