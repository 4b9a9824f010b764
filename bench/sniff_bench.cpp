// `lec sniff`'s decoder (modbus::Sniffer): frames per second on one core, for
// BENCHMARKS.md ("lec sniff"). A stream of read/write exchanges from the twin's
// bus at 230400 baud is fed either frame by frame (an adapter with a 1 ms
// latency timer) or in 4 KiB reads (a lumping adapter, or --read).
// items_per_second = frames decoded; the line carries at most
// 230400 / 10 / (8 + 9) ≈ 1355 exchanges/s, i.e. ≈ 2710 frames/s.

#include <benchmark/benchmark.h>

#include "lec6/modbus/crc.hpp"
#include "lec6/modbus/sniffer.hpp"
#include "lec6/sim/bus.hpp"

namespace {

using namespace lec6;
using modbus::Bytes;

struct Stream {
  std::vector<std::pair<Bytes, TimePoint>> frames;
};

const Stream& stream() {
  static const Stream s = [] {
    Stream out;
    sim::LineConfig config;
    config.line.baud = 230400;
    sim::Bus bus(config);
    bus.add(1);
    Bytes read{0x01, 0x03, 0x90, 0x00, 0x00, 0x02};
    modbus::append_crc(read);
    Bytes write{0x01, 0x05, 0x00, 0x19, 0xFF, 0x00};
    modbus::append_crc(write);
    TimePoint t = TimePoint{} + std::chrono::seconds(1);
    for (int i = 0; i < 10'000; ++i) {
      const Bytes& q = i % 4 == 3 ? write : read;
      out.frames.emplace_back(q, t + config.line.wire_time(q.size()));
      auto r = sim::transact(bus, q, t);
      out.frames.emplace_back(r->bytes, r->end);
      t = r->end + config.line.silent_interval();
    }
    return out;
  }();
  return s;
}

void BM_Sniffer_PerFrame(benchmark::State& state) {
  const Stream& s = stream();
  for (auto _ : state) {
    modbus::SnifferOptions o;
    o.timing.baud = 230400;
    modbus::Sniffer sniffer(o);
    std::size_t events = 0;
    for (const auto& [bytes, at] : s.frames) {
      sniffer.feed(bytes, at);
      events += sniffer.take().size();
    }
    benchmark::DoNotOptimize(events);
  }
  state.SetItemsProcessed(state.iterations() * static_cast<int64_t>(s.frames.size()));
}
BENCHMARK(BM_Sniffer_PerFrame)->Unit(benchmark::kMillisecond);

void BM_Sniffer_Lumps4k(benchmark::State& state) {
  const Stream& s = stream();
  Bytes all;
  for (const auto& f : s.frames) all.insert(all.end(), f.first.begin(), f.first.end());
  for (auto _ : state) {
    modbus::Sniffer sniffer;
    std::size_t events = 0;
    TimePoint t{};
    for (std::size_t i = 0; i < all.size(); i += 4096) {
      t += std::chrono::milliseconds(16);
      sniffer.feed(std::span<const uint8_t>(all).subspan(i, std::min<std::size_t>(4096, all.size() - i)), t);
      events += sniffer.take().size();
    }
    benchmark::DoNotOptimize(events);
  }
  state.SetItemsProcessed(state.iterations() * static_cast<int64_t>(s.frames.size()));
}
BENCHMARK(BM_Sniffer_Lumps4k)->Unit(benchmark::kMillisecond);

}  // namespace
