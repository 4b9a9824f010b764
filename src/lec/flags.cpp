#include "lec6/lec/flags.hpp"

namespace lec6::lec {

std::string_view coil_name(uint16_t coil) noexcept {
  switch (coil) {
    case 0x10:
      return "IN0";
    case 0x11:
      return "IN1";
    case 0x12:
      return "IN2";
    case 0x13:
      return "IN3";
    case 0x14:
      return "IN4";
    case 0x15:
      return "IN5";
    case 0x18:
      return "HOLD";
    case 0x19:
      return "SVON";
    case 0x1A:
      return "DRIVE";
    case 0x1B:
      return "RESET";
    case 0x1C:
      return "SETUP";
    case 0x1D:
      return "JOG-";
    case 0x1E:
      return "JOG+";
    case 0x30:
      return "input invalid flag (serial mode)";
    default:
      return {};
  }
}

std::string_view status_flag_name(unsigned bit) noexcept {
  static constexpr std::string_view kNames[16] = {"OUT0", "OUT1",  "OUT2",  "OUT3", "OUT4",  "OUT5",
                                                  "—",    "—",     "BUSY",  "SVRE", "SETON", "INP",
                                                  "AREA", "WAREA", "ESTOP", "ALARM"};
  return bit < 16 ? kNames[bit] : std::string_view{};
}

StatusFlags StatusFlags::from_packed(std::span<const uint8_t> packed) noexcept {
  StatusFlags f;
  if (!packed.empty()) f.bits = packed[0];
  if (packed.size() > 1) f.bits = static_cast<uint16_t>(f.bits | (packed[1] << 8));
  return f;
}

std::array<uint8_t, 2> StatusFlags::packed() const noexcept {
  return {static_cast<uint8_t>(bits & 0xFF), static_cast<uint8_t>(bits >> 8)};
}

std::string StatusFlags::describe() const {
  std::string out;
  for (unsigned b = 8; b < 16; ++b) {
    if ((bits >> b) & 1U) {
      if (!out.empty()) out += ' ';
      out += status_flag_name(b);
    }
  }
  if (out.empty()) out = "(none)";
  return out;
}

}  // namespace lec6::lec
