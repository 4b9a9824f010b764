// CRC-16/MODBUS throughput: the library's crc16 (table-driven, slicing-by-8:
// eight independent lookups per eight bytes), the classic byte-wise table it
// replaced (one lookup per byte, each depending on the last), and the manual's
// bit-by-bit procedure (§11), the reference both are tested against.
//
// Frames are at most 260 bytes, so the sizes that matter for the protocol are
// 8 (a read request) to 260; the large sizes show the asymptotic rate.

#include <benchmark/benchmark.h>

#include <cstdint>
#include <random>
#include <span>
#include <vector>

#include "lec6/modbus/crc.hpp"

namespace {

using lec6::modbus::crc16;
using lec6::modbus::crc16_bitwise;

std::vector<uint8_t> random_bytes(std::size_t n) {
  std::mt19937 rng(42);
  std::vector<uint8_t> v(n);
  for (auto& b : v) b = static_cast<uint8_t>(rng());
  return v;
}

// One table lookup per byte: the loop-carried dependency runs through a load.
uint16_t crc16_bytewise(std::span<const uint8_t> data) noexcept {
  const auto& t = lec6::modbus::detail::kCrcTables[0];
  uint16_t crc = 0xFFFF;
  for (uint8_t b : data) crc = static_cast<uint16_t>((crc >> 8) ^ t[(crc ^ b) & 0xFFU]);
  return crc;
}

template <uint16_t (*Crc)(std::span<const uint8_t>) noexcept>
void run_crc(benchmark::State& state) {
  const auto data = random_bytes(static_cast<std::size_t>(state.range(0)));
  // Every variant must agree with the manual's procedure before its speed means anything.
  if (Crc(data) != crc16_bitwise(data)) {
    state.SkipWithError("CRC differs from the manual's bit-by-bit procedure");
    return;
  }
  for (auto _ : state) {
    benchmark::DoNotOptimize(data.data());
    uint16_t c = Crc(data);
    benchmark::DoNotOptimize(c);
  }
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations()) * state.range(0));
}

// crc16 is constexpr and inline; call it through a function so every variant
// is measured the same way.
uint16_t library_crc(std::span<const uint8_t> d) noexcept {
  return crc16(d);
}
uint16_t bitwise_crc(std::span<const uint8_t> d) noexcept {
  return crc16_bitwise(d);
}

void BM_Crc16_Table(benchmark::State& s) {
  run_crc<library_crc>(s);
}
void BM_Crc16_ByteTable(benchmark::State& s) {
  run_crc<crc16_bytewise>(s);
}
void BM_Crc16_Bitwise(benchmark::State& s) {
  run_crc<bitwise_crc>(s);
}

BENCHMARK(BM_Crc16_Table)->Arg(8)->Arg(19)->Arg(260)->Arg(4096)->Arg(1 << 16);
BENCHMARK(BM_Crc16_ByteTable)->Arg(8)->Arg(19)->Arg(260)->Arg(4096)->Arg(1 << 16);
BENCHMARK(BM_Crc16_Bitwise)->Arg(8)->Arg(260)->Arg(4096);

}  // namespace
