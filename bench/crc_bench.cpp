// CRC-16/MODBUS throughput: the library's table-driven crc16 (one lookup per
// byte), the manual's bit-by-bit reference, and a slicing-by-8 candidate
// (eight tables, eight bytes per step) that shows what a table-driven CRC can
// do on this machine when the per-byte dependency chain is broken.
//
// Frames are at most 260 bytes, so the sizes that matter for the protocol are
// 8 (a read request) to 260; the large sizes show the asymptotic rate.

#include <benchmark/benchmark.h>

#include <array>
#include <bit>
#include <cstdint>
#include <cstring>
#include <random>
#include <span>
#include <stdexcept>
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

// Slicing-by-8 for the reflected polynomial 0xA001: table[k][b] is the CRC
// contribution of byte b followed by k zero bytes.
struct Slice8 {
  std::array<std::array<uint16_t, 256>, 8> t{};
  constexpr Slice8() {
    for (unsigned b = 0; b < 256; ++b) t[0][b] = lec6::modbus::detail::kCrcTables[0][b];
    for (unsigned b = 0; b < 256; ++b) {
      for (std::size_t k = 1; k < 8; ++k) {
        const uint16_t prev = t[k - 1][b];
        t[k][b] = static_cast<uint16_t>((prev >> 8) ^ t[0][prev & 0xFFU]);
      }
    }
  }
};
constexpr Slice8 kSlice8{};

uint16_t crc16_slice8(std::span<const uint8_t> data) noexcept {
  uint32_t crc = 0xFFFF;
  const uint8_t* p = data.data();
  std::size_t n = data.size();
  const auto& t = kSlice8.t;
  while (n >= 8) {
    uint32_t lo = 0;
    uint32_t hi = 0;
    std::memcpy(&lo, p, 4);
    std::memcpy(&hi, p + 4, 4);
    lo ^= crc;  // little-endian host: the CRC's low byte meets the first data byte
    crc = static_cast<uint32_t>(
        t[7][lo & 0xFFU] ^ t[6][(lo >> 8) & 0xFFU] ^ t[5][(lo >> 16) & 0xFFU] ^ t[4][lo >> 24] ^
        t[3][hi & 0xFFU] ^ t[2][(hi >> 8) & 0xFFU] ^ t[1][(hi >> 16) & 0xFFU] ^ t[0][hi >> 24]);
    p += 8;
    n -= 8;
  }
  while (n--) crc = (crc >> 8) ^ t[0][(crc ^ *p++) & 0xFFU];
  return static_cast<uint16_t>(crc);
}

static_assert(std::endian::native == std::endian::little,
              "crc16_slice8 assumes a little-endian host");

template <uint16_t (*Crc)(std::span<const uint8_t>) noexcept>
void run_crc(benchmark::State& state) {
  const auto data = random_bytes(static_cast<std::size_t>(state.range(0)));
  // The candidate must agree with the library before its speed means anything.
  if (Crc(data) != crc16(data)) {
    state.SkipWithError("CRC differs from lec6::modbus::crc16");
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
void BM_Crc16_Bitwise(benchmark::State& s) {
  run_crc<bitwise_crc>(s);
}
void BM_Crc16_Slice8(benchmark::State& s) {
  run_crc<crc16_slice8>(s);
}

BENCHMARK(BM_Crc16_Table)->Arg(8)->Arg(19)->Arg(260)->Arg(4096)->Arg(1 << 16);
BENCHMARK(BM_Crc16_Bitwise)->Arg(8)->Arg(260)->Arg(4096);
BENCHMARK(BM_Crc16_Slice8)->Arg(8)->Arg(19)->Arg(260)->Arg(4096)->Arg(1 << 16);

}  // namespace
