#pragma once
// Big-endian 16-bit words as Modbus carries them (private to modbus/).

#include <cstddef>
#include <cstdint>
#include <span>

#include "lec6/modbus/pdu.hpp"

namespace lec6::modbus::detail {

inline void put16(Bytes& out, uint16_t v) {
  out.push_back(static_cast<uint8_t>(v >> 8));
  out.push_back(static_cast<uint8_t>(v & 0xFF));
}

inline uint16_t get16(std::span<const uint8_t> in, std::size_t at) {
  return static_cast<uint16_t>((in[at] << 8) | in[at + 1]);
}

}  // namespace lec6::modbus::detail
