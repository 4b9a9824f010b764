#pragma once
// The LEC□6 memory map (digest §4) as data, and the controller's access rules
// (digest §2–§3) as one function. The twin answers with it and the client
// checks its own requests with it, so both sides share one definition.
//
// Thread safety: constant data and pure functions.

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>

#include "lec6/modbus/pdu.hpp"

namespace lec6::lec {

enum class Space : uint8_t { Coil, Input, Register };  // Y (FC01/05/0F), X (FC02), D (FC03/10)

struct Area {
  Space space;
  uint16_t first;
  uint16_t last;
  std::string_view name;
};

// Every area of digest §4. Reads may span undefined addresses inside one area.
std::span<const Area> areas() noexcept;
const Area* find_area(Space space, uint16_t address) noexcept;

// Who may write an address.
enum class WriteRule : uint8_t {
  Refused,         // read-only or undefined → exception 02
  Always,          // in either input mode (Y30, D90C2, step data, direct-operation data)
  SerialModeOnly,  // only with Y30 = 1 (Y10–Y1F, D90C1, D9100) (digest §3, assumed)
};
WriteRule write_rule(Space space, uint16_t address) noexcept;

// Register addresses (PDU addresses; "D9000" is 0x9000).
inline constexpr uint16_t kEquipmentName = 0x000E;
inline constexpr uint16_t kEquipmentNameRegisters = 8;
inline constexpr uint16_t kAlarmHistory = 0x0380;
inline constexpr uint16_t kAlarmHistoryRegisters = 64;
inline constexpr uint16_t kStepData = 0x0400;
inline constexpr uint16_t kStepCount = 64;
inline constexpr uint16_t kStepStride = 0x10;
inline constexpr uint16_t kStateData = 0x9000;
inline constexpr uint16_t kStateDataRegisters = 7;
inline constexpr uint16_t kStatusWord = 0x9084;      // X40–X4F as one word
inline constexpr uint16_t kControlWordY10 = 0x90C1;  // Y10–Y1F as one word
inline constexpr uint16_t kControlWordY30 = 0x90C2;  // Y30–Y3F as one word
inline constexpr uint16_t kDirectStart = 0x9100;
inline constexpr uint16_t kDirectStartValue = 0x0100;  // high byte 1: start
inline constexpr uint16_t kDirectData = 0x9102;
inline constexpr uint16_t kStatusInputs = 0x40;  // X40
inline constexpr uint16_t kStatusInputCount = 16;

constexpr uint16_t step_address(unsigned step) noexcept {
  return static_cast<uint16_t>(kStepData + kStepStride * step);
}

// Why the controller refuses a request: its exception code and the rule.
struct Refusal {
  modbus::ExceptionCode code;
  std::string reason;
};

// Applies every rule of digest §2–§3 to a decoded request, in the digest's
// order: count bounds and byte count (03) → start in an area (02) → last
// address in the start's area (03) → write permission and input mode (02) →
// written value (FC05, 03). `serial_mode` is Y30. Unknown function codes (01)
// never decode, so the caller answers those.
std::optional<Refusal> check_request(const modbus::Request& request, bool serial_mode);

// The likely cause of an exception, for people: what to do about it.
std::string explain_exception(modbus::ExceptionCode code);

// A name for an address in the manual's terms: "Y19 SVON", "D9000 current position",
// "D0412 step 1 position". Empty when the address has no name.
std::string address_name(Space space, uint16_t address);

}  // namespace lec6::lec
