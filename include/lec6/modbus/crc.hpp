#pragma once
// CRC-16/MODBUS (manual §11): reflected polynomial 0xA001, preset 0xFFFF,
// appended to a frame low byte first.
//
// Thread safety: pure functions (the tables are built at compile time).

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

namespace lec6::modbus {

namespace detail {
// kCrcTables[0] is the classic byte table; kCrcTables[k] advances a byte's
// contribution k more bytes, so eight bytes fold in with eight independent
// lookups (slicing-by-8) instead of a chain of eight dependent ones.
constexpr std::array<std::array<uint16_t, 256>, 8> make_crc_tables() {
  std::array<std::array<uint16_t, 256>, 8> t{};
  for (unsigned byte = 0; byte < 256; ++byte) {
    uint16_t crc = static_cast<uint16_t>(byte);
    for (int bit = 0; bit < 8; ++bit) {
      crc = (crc & 1U) ? static_cast<uint16_t>((crc >> 1) ^ 0xA001U)
                       : static_cast<uint16_t>(crc >> 1);
    }
    t[0][byte] = crc;
  }
  for (std::size_t k = 1; k < 8; ++k) {
    for (unsigned byte = 0; byte < 256; ++byte) {
      const uint16_t prev = t[k - 1][byte];
      t[k][byte] = static_cast<uint16_t>((prev >> 8) ^ t[0][prev & 0xFFU]);
    }
  }
  return t;
}
inline constexpr auto kCrcTables = make_crc_tables();
}  // namespace detail

// Table-driven (slicing-by-8 for the bulk, one lookup per byte for the rest).
// Usable at compile time.
// `crc16_update(crc16(a), b)` is the CRC of a followed by b; a frame with its
// CRC appended has CRC 0 (the check of a frame too long to keep whole).
constexpr uint16_t crc16_update(uint16_t crc, std::span<const uint8_t> data) noexcept {
  const auto& t = detail::kCrcTables;
  std::size_t i = 0;
  for (; i + 8 <= data.size(); i += 8) {
    const uint16_t c = static_cast<uint16_t>(crc ^ (data[i] | (data[i + 1] << 8)));
    crc = static_cast<uint16_t>(t[7][c & 0xFFU] ^ t[6][c >> 8] ^ t[5][data[i + 2]] ^
                                t[4][data[i + 3]] ^ t[3][data[i + 4]] ^ t[2][data[i + 5]] ^
                                t[1][data[i + 6]] ^ t[0][data[i + 7]]);
  }
  for (; i < data.size(); ++i) {
    crc = static_cast<uint16_t>((crc >> 8) ^ t[0][(crc ^ data[i]) & 0xFFU]);
  }
  return crc;
}

constexpr uint16_t crc16(std::span<const uint8_t> data) noexcept {
  return crc16_update(0xFFFF, data);
}

// The bit-by-bit procedure exactly as manual §11 words it; the reference the
// table-driven version is tested against.
uint16_t crc16_bitwise(std::span<const uint8_t> data) noexcept;

// True when the last two bytes of `adu` are the CRC of the rest (low byte first).
constexpr bool crc_ok(std::span<const uint8_t> adu) noexcept {
  if (adu.size() < 3) return false;
  const uint16_t crc = crc16(adu.first(adu.size() - 2));
  return adu[adu.size() - 2] == (crc & 0xFFU) && adu[adu.size() - 1] == (crc >> 8);
}

}  // namespace lec6::modbus
