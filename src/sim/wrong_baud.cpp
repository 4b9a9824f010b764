// The wrong-baud rule (see the header).

#include "lec6/sim/wrong_baud.hpp"

namespace lec6::sim {

modbus::Bytes garble_wrong_baud(std::span<const uint8_t> bytes) {
  modbus::Bytes out;
  out.reserve((bytes.size() + 1) / 2);
  for (std::size_t i = 0; i < bytes.size(); i += 2)
    out.push_back(static_cast<uint8_t>(bytes[i] ^ 0x5A));
  return out;
}

}  // namespace lec6::sim
