// The USB adapter's latency timer, on virtual time.

#include "lec6/sim/usb_latency.hpp"

#include <gtest/gtest.h>

namespace lec6::sim {
namespace {

using namespace std::chrono_literals;
using modbus::Bytes;

const TimePoint t0_usb{};

TEST(UsbLatency, LumpsBytesAtTimerTicks) {
  UsbLatency usb(16ms);
  const Bytes a{1, 2, 3}, b{4, 5};
  usb.push(a, t0_usb + 1ms);
  usb.push(b, t0_usb + 10ms);  // the same timer period: the same lump
  EXPECT_EQ(usb.next_delivery(), t0_usb + 16ms);
  EXPECT_TRUE(usb.take(t0_usb + 15ms).empty());
  const auto d = usb.take(t0_usb + 16ms);
  ASSERT_EQ(d.size(), 1u);
  EXPECT_EQ(d[0].at, t0_usb + 16ms);
  EXPECT_EQ(d[0].bytes, (Bytes{1, 2, 3, 4, 5}));
  EXPECT_FALSE(usb.next_delivery());
}

TEST(UsbLatency, ANewPeriodStartsANewLump) {
  UsbLatency usb(16ms);
  usb.push(Bytes{1}, t0_usb + 15ms);
  usb.push(Bytes{2}, t0_usb + 17ms);  // after the first tick: the next one
  const auto d = usb.take(t0_usb + 40ms);
  ASSERT_EQ(d.size(), 2u);
  EXPECT_EQ(d[0].at, t0_usb + 16ms);
  EXPECT_EQ(d[0].bytes, Bytes{1});
  EXPECT_EQ(d[1].at, t0_usb + 32ms);
  EXPECT_EQ(d[1].bytes, Bytes{2});
}

TEST(UsbLatency, AFullPacketGoesAtOnce) {
  UsbLatency usb(16ms, 4);
  usb.push(Bytes{1, 2, 3, 4, 5, 6}, t0_usb + 2ms);
  const auto d = usb.take(t0_usb + 2ms);
  ASSERT_EQ(d.size(), 1u);
  EXPECT_EQ(d[0].at, t0_usb + 2ms);
  EXPECT_EQ(d[0].bytes, (Bytes{1, 2, 3, 4}));
  EXPECT_EQ(usb.next_delivery(), t0_usb + 16ms);
  EXPECT_EQ(usb.take(t0_usb + 16ms).at(0).bytes, (Bytes{5, 6}));
}

TEST(UsbLatency, ZeroLatencyDeliversEachPushAsIs) {
  UsbLatency usb(0ms);
  usb.push(Bytes{1, 2}, t0_usb + 1ms);
  usb.push(Bytes{3}, t0_usb + 2ms);
  EXPECT_EQ(usb.next_delivery(), t0_usb + 1ms);
  const auto d = usb.take(t0_usb + 5ms);
  ASSERT_EQ(d.size(), 2u);
  EXPECT_EQ(d[0].at, t0_usb + 1ms);
  EXPECT_EQ(d[1].bytes, Bytes{3});
}

TEST(UsbLatency, NoByteIsLostOrReordered) {
  UsbLatency usb(16ms);
  Bytes in, out;
  for (int i = 0; i < 10000; ++i) {
    const auto b = static_cast<uint8_t>(i);
    in.push_back(b);
    usb.push(std::span<const uint8_t>(&b, 1), t0_usb + std::chrono::microseconds(i * 87));
    for (auto& d : usb.take(t0_usb + std::chrono::microseconds(i * 87)))
      out.insert(out.end(), d.bytes.begin(), d.bytes.end());
  }
  for (auto& d : usb.take(t0_usb + 10s)) out.insert(out.end(), d.bytes.begin(), d.bytes.end());
  EXPECT_EQ(out, in);
}

}  // namespace
}  // namespace lec6::sim
