#pragma once
// The internal flags (digest §4, manual §10.3): X40–X4F status inputs and the
// Y coils the master drives.
//
// Thread safety: value types and pure functions; const objects may be shared between threads,
// writes need the caller's synchronisation.

#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>

namespace lec6::lec {

// Y coils, by their manual names and addresses.
enum class Coil : uint16_t {
  IN0 = 0x10,
  IN1 = 0x11,
  IN2 = 0x12,
  IN3 = 0x13,
  IN4 = 0x14,
  IN5 = 0x15,
  HOLD = 0x18,
  SVON = 0x19,
  DRIVE = 0x1A,
  RESET = 0x1B,
  SETUP = 0x1C,
  JOG_MINUS = 0x1D,
  JOG_PLUS = 0x1E,
  SerialMode = 0x30,  // the manual's "input invalid flag": 1 = serial input mode
};

constexpr uint16_t address(Coil c) noexcept {
  return static_cast<uint16_t>(c);
}
// "SVON", "IN3", "input invalid flag (serial mode)"; empty for unnamed coils.
std::string_view coil_name(uint16_t coil) noexcept;

// X40–X4F. ESTOP and ALARM are positive logic (1 = stop active / alarm present).
struct StatusFlags {
  enum Bit : uint8_t {
    Out0 = 0,
    Out1,
    Out2,
    Out3,
    Out4,
    Out5,
    Busy = 8,
    Svre,
    Seton,
    Inp,
    Area,
    Warea,
    Estop,
    Alarm,
  };

  uint16_t bits = 0;  // bit 0 = X40

  constexpr bool test(Bit b) const noexcept { return (bits >> b) & 1U; }
  constexpr void set(Bit b, bool on) noexcept {
    bits = on ? static_cast<uint16_t>(bits | (1U << b)) : static_cast<uint16_t>(bits & ~(1U << b));
  }
  constexpr bool busy() const noexcept { return test(Busy); }
  constexpr bool svre() const noexcept { return test(Svre); }
  constexpr bool seton() const noexcept { return test(Seton); }
  constexpr bool inp() const noexcept { return test(Inp); }
  constexpr bool area() const noexcept { return test(Area); }
  constexpr bool warea() const noexcept { return test(Warea); }
  constexpr bool estop() const noexcept { return test(Estop); }
  constexpr bool alarm() const noexcept { return test(Alarm); }
  // OUT0–OUT5: the number of the step that was started.
  constexpr uint8_t out() const noexcept { return static_cast<uint8_t>(bits & 0x3F); }
  constexpr void set_out(uint8_t step) noexcept {
    bits = static_cast<uint16_t>((bits & ~0x3FU) | (step & 0x3FU));
  }

  // From/to the two bytes of an FC02 reply for X40×16 (LSB first: X40 is bit 0 of byte 0).
  static StatusFlags from_packed(std::span<const uint8_t> packed) noexcept;
  std::array<uint8_t, 2> packed() const noexcept;

  // "BUSY SVRE INP" — the names of the flags that are on.
  std::string describe() const;
  bool operator==(const StatusFlags&) const = default;
};

// "OUT0".."OUT5", "BUSY", ... for bit 0..15 (X40 + bit); "—" for unused.
std::string_view status_flag_name(unsigned bit) noexcept;

// Y10–Y1F and Y30 as the master sees them.
struct ControlFlags {
  uint16_t y10_1f = 0;       // bit 0 = Y10
  bool serial_mode = false;  // Y30

  constexpr bool test(Coil c) const noexcept {
    if (c == Coil::SerialMode) return serial_mode;
    return (y10_1f >> (address(c) - 0x10)) & 1U;
  }
  constexpr void set(Coil c, bool on) noexcept {
    if (c == Coil::SerialMode) {
      serial_mode = on;
      return;
    }
    const unsigned bit = address(c) - 0x10U;
    y10_1f = on ? static_cast<uint16_t>(y10_1f | (1U << bit))
                : static_cast<uint16_t>(y10_1f & ~(1U << bit));
  }
  // IN0–IN5: the selected step number.
  constexpr uint8_t selected_step() const noexcept { return static_cast<uint8_t>(y10_1f & 0x3F); }
  bool operator==(const ControlFlags&) const = default;
};

}  // namespace lec6::lec
