// RtuOptions::reply_spin on a real pseudo-terminal (a fast twin answers in
// tens of microseconds): replies are read with it as without it, a controller
// that does not answer still times out at the transaction's deadline (the
// spin is a bound, not a wait of its own), and on the virtual clock, which
// stands still while nothing waits on it, the master does not spin at all.

#include <gtest/gtest.h>

#include "client/sim_fixture.hpp"
#include "lec6/client/client.hpp"
#include "lec6/client/rtu_master.hpp"
#include "lec6/transport/serial_link.hpp"
#include "twin/served_twin.hpp"

namespace lec6::twin {
namespace {

using namespace std::chrono_literals;

sim::LineConfig fast_line() {
  sim::LineConfig line;
  line.timing = sim::Timing::Fast;
  return line;
}

client::ClientOptions spinning() {
  client::ClientOptions o;
  o.wait_for_silence = false;
  o.reply_spin = client::kFastReplySpin;
  return o;
}

TEST(ReplySpin, AFastTwinsRepliesReadAsWithout) {
  testing::ServedTwin twin({1}, testing::pty_only(), fast_line());
  transport::SerialLink link(twin.path(), transport::SerialOptions{.baud = 230400});
  // A wide reply window: a reply the spin failed to read still times out
  // (every read would), but a twin a loaded host stalls for 50 ms does not
  // (make test, 2026-11-29: one timeout of 500 reads beside the other tests).
  client::ClientOptions o = spinning();
  o.timeout_margin = 500ms;
  client::Client c(link, o);
  for (int i = 0; i < 500; ++i) ASSERT_NO_THROW(c.read_state()) << "read " << i;
  EXPECT_EQ(c.stats().timeouts, 0u);
}

TEST(ReplySpin, AnIdThatDoesNotAnswerStillTimesOutAtItsDeadline) {
  testing::ServedTwin twin({1}, testing::pty_only(), fast_line());
  transport::SerialLink link(twin.path(), transport::SerialOptions{.baud = 230400});
  client::ClientOptions o = spinning();
  o.reply_spin = Duration::max();  // clamped to kMaxReplySpin: no overflow, no hour of spinning
  o.retries = 0;
  o.timeout_margin = 40ms;
  client::Client c(link, o);
  c.set_id(7);
  const SteadyClock clock;
  const TimePoint began = clock.now();
  EXPECT_THROW(c.read_state(), client::TransportError);
  const Duration took = clock.now() - began;
  EXPECT_GE(took, 40ms) << "the deadline is the reply window, not the spin";
  EXPECT_LT(took, 1s);
}

TEST(ReplySpin, OnTheVirtualClockTheMasterDoesNotSpin) {
  lec6::testing::SimFixture f(fast_line());
  client::RtuOptions o;
  o.wait_for_silence = false;
  o.reply_spin = 1s;  // would never end on a clock that stands still
  client::RtuMaster master(*f.link, o);
  const modbus::RequestFrame read{1, modbus::ReadRegistersRequest{0x9000, 7}};
  for (int i = 0; i < 10; ++i) EXPECT_NO_THROW(master.exchange(read));
  const modbus::RequestFrame nobody{7, modbus::ReadRegistersRequest{0x9000, 7}};
  EXPECT_THROW(master.exchange(nobody), client::TransportError);
}

}  // namespace
}  // namespace lec6::twin
