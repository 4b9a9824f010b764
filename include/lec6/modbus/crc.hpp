#pragma once
// CRC-16/MODBUS (manual §11): reflected polynomial 0xA001, preset 0xFFFF,
// appended to a frame low byte first.

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

namespace lec6::modbus {

namespace detail {
constexpr std::array<uint16_t, 256> make_crc_table() {
  std::array<uint16_t, 256> table{};
  for (unsigned byte = 0; byte < 256; ++byte) {
    uint16_t crc = static_cast<uint16_t>(byte);
    for (int bit = 0; bit < 8; ++bit) {
      crc = (crc & 1U) ? static_cast<uint16_t>((crc >> 1) ^ 0xA001U)
                       : static_cast<uint16_t>(crc >> 1);
    }
    table[byte] = crc;
  }
  return table;
}
inline constexpr std::array<uint16_t, 256> kCrcTable = make_crc_table();
}  // namespace detail

// Table-driven: one lookup per byte. Usable at compile time.
constexpr uint16_t crc16(std::span<const uint8_t> data) noexcept {
  uint16_t crc = 0xFFFF;
  for (uint8_t b : data) {
    crc = static_cast<uint16_t>((crc >> 8) ^ detail::kCrcTable[(crc ^ b) & 0xFFU]);
  }
  return crc;
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
