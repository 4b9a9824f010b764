// `lec sniff`'s framing against the twin's bus on virtual time: 10^5
// exchanges (10^4 under the sanitizers), delivered per frame, in a USB adapter's 16 ms lumps (at
// 115200 and 9600 baud) and with noise bursts between them. Every frame the bus put on the line
// comes out, paired, none lost, merged or split; every noise burst comes out as noise.

#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "lec6/modbus/crc.hpp"
#include "lec6/modbus/sniffer.hpp"
#include "lec6/sim/bus.hpp"
#include "lec6/sim/usb_latency.hpp"
#include "sanitized.hpp"

namespace lec6::sim {
namespace {

using namespace std::chrono_literals;
using modbus::Bytes;
using modbus::SniffEvent;
using modbus::SniffKind;

// 10^4 under the sanitizers (sanitized.hpp).
constexpr int kExchanges = testing::sanitized(100'000, 10'000);

struct Piece {
  Bytes bytes;
  TimePoint end;  // the last byte's arrival
  SniffKind kind;
};

Bytes framed(std::initializer_list<uint8_t> body) {
  Bytes b(body);
  modbus::append_crc(b);
  return b;
}

// The queries a master cycles through: reads of X, Y, D and writes.
std::vector<Bytes> queries(uint8_t id) {
  return {framed({id, 0x03, 0x90, 0x00, 0x00, 0x02}),  // D9000 x2 (position)
          framed({id, 0x02, 0x00, 0x40, 0x00, 0x10}),  // X40.. x16
          framed({id, 0x01, 0x00, 0x10, 0x00, 0x08}),  // Y10.. x8
          framed({id, 0x05, 0x00, 0x19, 0xFF, 0x00}),  // SVON ON
          framed({id, 0x03, 0x90, 0x00, 0x00, 0x0C}),  // D9000 x12
          framed({id, 0x10, 0x91, 0x02, 0x00, 0x02, 0x04, 0x00, 0x00, 0x00, 0x64}),
          framed({id, 0x03, 0x00, 0x00, 0x00, 0x01})};  // an address the LEC refuses
}

// Master-paced exchanges on the bus, with `noise_every`-th gap holding a burst.
std::vector<Piece> line(uint32_t baud, int noise_every, std::vector<Bytes>* noise) {
  LineConfig config;
  config.line.baud = baud;
  Bus bus(config);
  bus.add(1);
  bus.add(2);
  const auto q1 = queries(1), q2 = queries(2);
  std::mt19937 rng(7);
  std::vector<Piece> out;
  out.reserve(2 * kExchanges + 1000);
  TimePoint t = TimePoint{} + 1s;
  const Duration ts = config.line.silent_interval();
  for (int i = 0; i < kExchanges; ++i) {
    const Bytes& q = (i % 3 == 2 ? q2 : q1)[static_cast<std::size_t>(i) % q1.size()];
    out.push_back({q, t + config.line.wire_time(q.size()), SniffKind::Query});
    auto r = transact(bus, q, t);
    if (!r) throw std::runtime_error("the bus did not answer");
    out.push_back({r->bytes, r->end, SniffKind::Reply});
    t = r->end + ts + std::chrono::microseconds(rng() % 2000);
    if (noise_every > 0 && i % noise_every == 0) {
      Bytes burst(1 + rng() % 6);
      for (auto& b : burst) b = static_cast<uint8_t>(rng());
      t += ts;
      t += config.line.wire_time(burst.size());
      out.push_back({burst, t, SniffKind::Noise});
      noise->push_back(burst);
      t += ts + 1ms;
    }
  }
  return out;
}

std::vector<SniffEvent> sniff(const std::vector<Piece>& pieces, uint32_t baud, Duration latency) {
  modbus::SnifferOptions o;
  o.timing.baud = baud;
  modbus::Sniffer sniffer(o);
  std::vector<SniffEvent> events;
  const auto drain = [&] {
    for (auto& e : sniffer.take()) events.push_back(std::move(e));
  };
  if (latency == Duration::zero()) {
    for (const auto& p : pieces) {
      sniffer.feed(p.bytes, p.end);
      drain();
    }
  } else {
    UsbLatency usb(latency);
    const Duration ch = modbus::LineTiming{baud}.char_time();
    for (const auto& p : pieces) {
      for (std::size_t i = 0; i < p.bytes.size(); ++i) {
        usb.push(std::span<const uint8_t>(&p.bytes[i], 1),
                 p.end - ch * static_cast<int64_t>(p.bytes.size() - 1 - i));
        for (auto& d : usb.take(p.end - ch * static_cast<int64_t>(p.bytes.size() - 1 - i)))
          sniffer.feed(d.bytes, d.at);
      }
      drain();
    }
    for (auto& d : usb.take(TimePoint::max())) sniffer.feed(d.bytes, d.at);
  }
  sniffer.finish(pieces.back().end + 10s);
  drain();
  return events;
}

// Every query and reply in order, each reply paired with the query before it.
void expect_every_frame(const std::vector<Piece>& pieces, const std::vector<SniffEvent>& events) {
  std::size_t e = 0;
  std::size_t frames = 0;
  for (const auto& p : pieces) {
    if (p.kind == SniffKind::Noise) continue;
    while (e < events.size() && events[e].kind == SniffKind::Noise) ++e;
    ASSERT_LT(e, events.size()) << "frame " << frames << " is missing";
    ASSERT_EQ(events[e].kind, p.kind) << "frame " << frames;
    ASSERT_EQ(events[e].bytes, p.bytes) << "frame " << frames;
    if (p.kind == SniffKind::Reply) {
      ASSERT_FALSE(events[e].has(modbus::kSniffUnsolicited)) << "frame " << frames;
      ASSERT_EQ(events[e].query, pieces[&p - &pieces[0] - 1].bytes) << "frame " << frames;
    }
    ++e;
    ++frames;
  }
  while (e < events.size() && events[e].kind == SniffKind::Noise) ++e;
  EXPECT_EQ(e, events.size()) << "events beyond the frames";
  EXPECT_EQ(frames, 2u * kExchanges);
}

TEST(SniffLine, EveryFrameAt115200PerFrame) {
  const auto pieces = line(115200, 0, nullptr);
  const auto events = sniff(pieces, 115200, Duration::zero());
  expect_every_frame(pieces, events);
  for (const auto& e : events) {
    ASSERT_EQ(
        e.flags & (modbus::kSniffLate | modbus::kSniffShortSilence | modbus::kSniffSecondMaster),
        0u);
    if (e.kind == SniffKind::Reply) {
      ASSERT_TRUE(e.response);
    }
  }
}

TEST(SniffLine, EveryFrameAt115200In16msLumps) {
  const auto pieces = line(115200, 0, nullptr);
  const auto events = sniff(pieces, 115200, 16ms);
  expect_every_frame(pieces, events);
}

TEST(SniffLine, EveryFrameAt9600In16msLumps) {
  const auto pieces = line(9600, 0, nullptr);
  const auto events = sniff(pieces, 9600, 16ms);
  expect_every_frame(pieces, events);
}

TEST(SniffLine, EveryNoiseBurstIsNoiseAndNoFrameIsLost) {
  std::vector<Bytes> noise;
  const auto pieces = line(115200, 100, &noise);
  for (const Duration latency : {Duration::zero(), Duration(16ms)}) {
    const auto events = sniff(pieces, 115200, latency);
    expect_every_frame(pieces, events);
    Bytes heard, sent;
    for (const auto& e : events)
      if (e.kind == SniffKind::Noise) heard.insert(heard.end(), e.bytes.begin(), e.bytes.end());
    for (const auto& b : noise) sent.insert(sent.end(), b.begin(), b.end());
    EXPECT_EQ(heard, sent);
    if (latency == Duration::zero()) {
      std::size_t bursts = 0;
      for (const auto& e : events) bursts += e.kind == SniffKind::Noise;
      EXPECT_EQ(bursts, noise.size());  // each burst on its own, when the gaps are seen
    }
  }
}

}  // namespace
}  // namespace lec6::sim
