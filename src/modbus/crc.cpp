#include "lec6/modbus/crc.hpp"

namespace lec6::modbus {

uint16_t crc16_bitwise(std::span<const uint8_t> data) noexcept {
  uint16_t crc = 0xFFFF;  // [I] preload FFFFh
  for (uint8_t b : data) {
    crc ^= b;                                  // [II]/[VI] XOR the next byte into the low byte
    for (int shift = 0; shift < 8; ++shift) {  // [V] eight shifts
      const bool carry = crc & 1U;
      crc >>= 1;                 // [III] shift toward the low bit, 0 into the top
      if (carry) crc ^= 0xA001;  // [IV]
    }
  }
  return crc;  // [VIII]
}

}  // namespace lec6::modbus
