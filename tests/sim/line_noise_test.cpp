// The twin's line beyond the digest's kind defaults: idle-line noise
// (FaultConfig::noise_rate) and frames longer than 260 bytes (digest §3:
// data > 256 B → exception 03), on a virtual time line.

#include <gtest/gtest.h>

#include <vector>

#include "lec6/modbus/crc.hpp"
#include "lec6/sim/bus.hpp"

#include "test_time.hpp"

namespace lec6::sim {
namespace {

using modbus::Bytes;

using testing::ms;

const TimePoint t0 = TimePoint{} + std::chrono::seconds(10);

Bytes with_crc(Bytes body) {
  modbus::append_crc(body);
  return body;
}

Bus noisy_bus(double rate, uint64_t seed = 5) {
  FaultConfig f;
  f.noise_rate = rate;
  f.seed = seed;
  Bus bus({}, f);
  bus.add(1);
  return bus;
}

// Every reply and noise byte the bus hands out until `until`.
std::vector<Reply> drain(Bus& bus, TimePoint until) {
  std::vector<Reply> out;
  TimePoint now = t0;
  bus.advance(now);
  for (;;) {
    for (auto& r : bus.take_replies(now)) out.push_back(std::move(r));
    const auto d = bus.next_deadline();
    if (!d || *d > until) break;
    now = std::max(now, *d);
    bus.advance(now);
  }
  return out;
}

TEST(Noise, RateAndSeedAreHonoured) {
  Bus a = noisy_bus(100);
  Bus b = noisy_bus(100);
  const auto na = drain(a, t0 + std::chrono::seconds(20));
  const auto nb = drain(b, t0 + std::chrono::seconds(20));
  ASSERT_EQ(na.size(), nb.size());
  for (std::size_t i = 0; i < na.size(); ++i) {
    EXPECT_TRUE(na[i].noise);
    EXPECT_EQ(na[i].id, 0);
    EXPECT_EQ(na[i].bytes, nb[i].bytes);
    EXPECT_EQ(na[i].end, nb[i].end);
  }
  // Poisson at 100/s over 20 s: 2000 ± 5 σ (σ ≈ 45).
  EXPECT_NEAR(static_cast<double>(na.size()), 2000.0, 225.0);
  EXPECT_EQ(a.stats().noise_bytes, na.size());
  Bus c = noisy_bus(100, 6);
  EXPECT_NE(drain(c, t0 + std::chrono::seconds(20)).front().end, na.front().end);
}

TEST(Noise, OffByDefaultAndNoDeadlines) {
  Bus bus;
  bus.add(1);
  bus.advance(t0);
  EXPECT_FALSE(bus.next_deadline());
  EXPECT_EQ(bus.stats().noise_bytes, 0u);
}

TEST(Noise, ASaturatingRateFillsTheLine) {
  Bus bus = noisy_bus(1e9);
  const auto n = drain(bus, t0 + ms(100));
  const Duration c = bus.line().line.char_time();
  // One byte per character time, back to back.
  EXPECT_NEAR(static_cast<double>(n.size()), to_ms(ms(100)) / to_ms(c), 3.0);
  for (std::size_t i = 1; i < n.size(); ++i) EXPECT_LT(n[i].end - n[i - 1].end, c + ms(0.001));
}

TEST(Noise, NeverOnTopOfAReply) {
  Bus bus = noisy_bus(2000);
  const Bytes query = with_crc({0x01, 0x03, 0x90, 0x00, 0x00, 0x07});
  std::vector<Reply> replies;
  TimePoint t = t0;
  for (int i = 0; i < 200; ++i) {
    auto r = transact(bus, query, t, ms(100));
    if (r) replies.push_back(*r);
    t += ms(40);
  }
  // Some queries are hit by noise (lost), most are answered.
  EXPECT_GT(replies.size(), 20u);
  EXPECT_LT(replies.size(), 200u);
  const auto noise = drain(bus, t);  // what is left is noise only
  for (const auto& n : noise) {
    for (const auto& r : replies) {
      EXPECT_FALSE(n.end - bus.line().line.char_time() < r.end && r.start < n.end)
          << "noise on a reply";
    }
  }
}

TEST(Noise, AByteJustBeforeAQueryCorruptsItAndOneTsEarlierDoesNot) {
  Bus bus;
  bus.add(1);
  const Bytes query = with_crc({0x01, 0x03, 0x90, 0x00, 0x00, 0x07});
  Bytes hit{0x55};  // a stray byte on the line right before the query's first
  hit.insert(hit.end(), query.begin(), query.end());
  EXPECT_FALSE(transact(bus, hit, t0));
  EXPECT_EQ(bus.stats().bad_frames, 1u);
  const TimePoint t1 = t0 + std::chrono::seconds(1);
  bus.receive(Bytes{0x55}, t1);  // the same byte, Ts before the query
  EXPECT_TRUE(transact(bus, query, t1 + bus.line().line.silent_interval()));
}

TEST(LongFrames, SoundFrameOverTheDataLimitGetsException03) {
  Bus bus;
  bus.add(1);
  // FC10 with 300 data bytes: legal shape on the wire, beyond 256 B of data.
  Bytes body{0x01, 0x10, 0x91, 0x02, 0x00, 0x10, 0x20};
  body.resize(body.size() + 300, 0x00);
  const Bytes frame = with_crc(body);
  ASSERT_GT(frame.size(), modbus::kMaxAdu);
  const auto r = transact(bus, frame, t0);
  ASSERT_TRUE(r);
  EXPECT_EQ(r->bytes, with_crc({0x01, 0x90, 0x03}));
  EXPECT_EQ(bus.stats().long_frames, 1u);
  // The registers were not touched.
  EXPECT_EQ(bus.find(1)->direct_data()[0], 0);
}

TEST(LongFrames, UnknownFunctionFirstThenSilenceForGarbage) {
  Bus bus;
  bus.add(1);
  Bytes body(270, 0x11);
  body[0] = 0x01;
  body[1] = 0x44;  // no such function: 01 comes first
  auto r = transact(bus, with_crc(body), t0);
  ASSERT_TRUE(r);
  EXPECT_EQ(r->bytes, with_crc({0x01, 0xC4, 0x01}));
  Bytes garbled = with_crc(body);
  garbled[100] ^= 0xFF;  // the CRC over the whole frame fails: silence
  EXPECT_FALSE(transact(bus, garbled, t0 + std::chrono::seconds(1)));
  Bytes other = body;
  other[0] = 0x07;  // an ID not on the line: silence
  EXPECT_FALSE(transact(bus, with_crc(other), t0 + std::chrono::seconds(2)));
  other[0] = 0x00;  // broadcast: never answered, never executed
  EXPECT_FALSE(transact(bus, with_crc(other), t0 + std::chrono::seconds(3)));
  EXPECT_EQ(bus.stats().long_frames, 1u);
}

TEST(LongFrames, ExactlyOneByteOverIsStillJudgedWhole) {
  Bus bus;
  bus.add(1);
  Bytes body(modbus::kMaxAdu - 1, 0x00);  // 259 + 2 CRC = 261 bytes
  body[0] = 0x01;
  body[1] = 0x0F;
  const auto r = transact(bus, with_crc(body), t0);
  ASSERT_TRUE(r);
  EXPECT_EQ(r->bytes, with_crc({0x01, 0x8F, 0x03}));
}

}  // namespace
}  // namespace lec6::sim
