// RtuOptions::spin_before_send, on a scripted link and the virtual clock: the
// master sleeps to the last stretch of Ts, polls the line without sleeping
// through it, sends at its end, and still hears a byte that comes meanwhile.

#include <gtest/gtest.h>

#include <optional>
#include <vector>

#include "lec6/client/rtu_master.hpp"

namespace lec6::client {
namespace {

using std::chrono::microseconds;

// A quiet line that answers nothing. A read with a deadline ahead sleeps to it;
// one with its deadline reached is a poll, which takes `poll_cost`.
class ScriptedLink final : public Link {
 public:
  std::vector<TimePoint> deadlines;   // of every read, in order
  std::optional<TimePoint> sent_at;   // when write() began
  std::optional<TimePoint> noise_at;  // one byte arrives then
  Duration poll_cost = microseconds(10);
  VirtualClock clock_;

  void write(std::span<const uint8_t>) override {
    if (!sent_at) sent_at = clock_.now();
  }
  std::size_t read_some(std::span<uint8_t> buffer, TimePoint deadline) override {
    deadlines.push_back(deadline);
    if (noise_at && *noise_at <= std::max(deadline, clock_.now())) {
      clock_.set(std::max(*noise_at, clock_.now()));
      noise_at.reset();
      buffer[0] = 0xFF;
      return 1;
    }
    clock_.set(deadline > clock_.now() ? deadline : clock_.now() + poll_cost);
    return 0;
  }
  void discard_input() override {}
  const Clock& clock() const override { return clock_; }
  uint32_t baud() const override { return 38400; }
  std::string describe() const override { return "scripted"; }
};

const modbus::RequestFrame kBroadcast{0, modbus::WriteCoilRequest{0x30, modbus::kCoilOn}};

TEST(SpinBeforeSend, SleepsToTheLastStretchOfTsThenPollsAndSendsAtItsEnd) {
  ScriptedLink link;
  const TimePoint t0 = link.clock_.now();
  RtuOptions o;
  o.spin_before_send = microseconds(200);
  RtuMaster master(link, o);
  master.exchange(kBroadcast);  // no reply: the master waits Tx, then is done
  const Duration ts = master.line_timing().silent_interval();
  ASSERT_TRUE(link.sent_at);
  ASSERT_GE(link.deadlines.size(), 3u);
  EXPECT_EQ(link.deadlines[0], t0 + ts - microseconds(200)) << "one sleep, to the spin";
  for (std::size_t i = 1; i < link.deadlines.size() && link.deadlines[i] < *link.sent_at; ++i)
    EXPECT_LE(link.deadlines[i], link.deadlines[i - 1] + link.poll_cost) << "polls, no sleep";
  EXPECT_GE(*link.sent_at, t0 + ts) << "never before Ts";
  EXPECT_LT(*link.sent_at, t0 + ts + link.poll_cost) << "within one poll of its end";
}

TEST(SpinBeforeSend, AByteDuringTheSpinStartsTsAgain) {
  ScriptedLink link;
  const TimePoint t0 = link.clock_.now();
  RtuOptions o;
  o.spin_before_send = microseconds(200);
  RtuMaster master(link, o);
  const Duration ts = master.line_timing().silent_interval();
  link.noise_at = t0 + ts - microseconds(50);
  master.exchange(kBroadcast);
  ASSERT_TRUE(link.sent_at);
  EXPECT_GE(*link.sent_at, *link.deadlines.begin() + microseconds(150) + ts);
  EXPECT_EQ(master.stats().bytes_discarded, 1u);
}

TEST(SpinBeforeSend, ZeroSleepsTheWholeWay) {
  ScriptedLink link;
  const TimePoint t0 = link.clock_.now();
  RtuMaster master(link, RtuOptions{});
  master.exchange(kBroadcast);
  const Duration ts = master.line_timing().silent_interval();
  ASSERT_TRUE(link.sent_at);
  EXPECT_EQ(link.deadlines[0], t0 + ts);
  EXPECT_EQ(*link.sent_at, t0 + ts);
}

}  // namespace
}  // namespace lec6::client
