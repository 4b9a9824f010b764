#include "lec6/modbus/timing.hpp"

namespace lec6::modbus {

bool is_supported_baud(uint32_t baud) noexcept {
  for (uint32_t b : kBaudRates) {
    if (b == baud) return true;
  }
  return false;
}

}  // namespace lec6::modbus
