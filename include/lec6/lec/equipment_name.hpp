#pragma once
// Equipment name D000E–D0015: 16 bytes of ASCII, at most 14 characters,
// NUL padded, first character in the high byte of D000E.
//
// Thread safety: value types and pure functions; const objects may be shared between threads,
// writes need the caller's synchronisation.

#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>

#include "lec6/expected.hpp"

namespace lec6::lec {

struct EquipmentName {
  static constexpr std::size_t kRegisters = 8;
  static constexpr std::size_t kMaxChars = 14;

  std::string text;

  // Refuses more than 14 characters and anything but printable ASCII.
  static Expected<EquipmentName, std::string> make(std::string_view text);

  std::array<uint16_t, kRegisters> to_registers() const noexcept;
  // Stops at the first NUL; non-printable bytes become '?'.
  static EquipmentName from_registers(std::span<const uint16_t> regs) noexcept;
  bool operator==(const EquipmentName&) const = default;
};

}  // namespace lec6::lec
