#include "lec6/lec/equipment_name.hpp"

#include <fmt/format.h>

#include <algorithm>

namespace lec6::lec {

Expected<EquipmentName, std::string> EquipmentName::make(std::string_view text) {
  if (text.size() > kMaxChars) {
    return unexpected(fmt::format("equipment name '{}' has {} characters; at most {} fit", text,
                                  text.size(), kMaxChars));
  }
  for (char c : text) {
    if (c < 0x20 || c > 0x7E) {
      return unexpected(fmt::format("equipment name '{}' must be printable ASCII", text));
    }
  }
  return EquipmentName{std::string(text)};
}

std::array<uint16_t, EquipmentName::kRegisters> EquipmentName::to_registers() const noexcept {
  std::array<uint8_t, kRegisters * 2> bytes{};
  std::copy_n(text.begin(), std::min(text.size(), kMaxChars), bytes.begin());
  std::array<uint16_t, kRegisters> regs{};
  for (std::size_t i = 0; i < kRegisters; ++i) {
    regs[i] = static_cast<uint16_t>((bytes[2 * i] << 8) | bytes[2 * i + 1]);
  }
  return regs;
}

EquipmentName EquipmentName::from_registers(std::span<const uint16_t> regs) noexcept {
  EquipmentName n;
  for (std::size_t i = 0; i < std::min(regs.size(), kRegisters); ++i) {
    for (uint8_t b : {static_cast<uint8_t>(regs[i] >> 8), static_cast<uint8_t>(regs[i] & 0xFF)}) {
      if (b == 0) return n;
      n.text.push_back(b >= 0x20 && b <= 0x7E ? static_cast<char>(b) : '?');
    }
  }
  return n;
}

}  // namespace lec6::lec
