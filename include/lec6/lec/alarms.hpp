#pragma once
// Alarm history D0380–D03BF (manual §10.5): 16 groups of 8 one-byte codes,
// group 0 the newest (the alarm being generated). Byte order inside a register
// is high byte first, like every other value (docs/protocol-decisions.md).
//
// Thread safety: value types and pure functions; const objects may be shared between threads,
// writes need the caller's synchronisation.

#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace lec6::lec {

// Alarm codes the twin raises and the client explains (digest §6).
namespace alarm {
inline constexpr uint8_t kInvalidData = 48;
inline constexpr uint8_t kStepNotRegistered = 51;
inline constexpr uint8_t kStepBeyondStroke = 52;
inline constexpr uint8_t kDirectBeyondStroke = 62;
inline constexpr uint8_t kOriginTimeout = 97;
inline constexpr uint8_t kServoOff = 98;
inline constexpr uint8_t kNotHomed = 99;
inline constexpr uint8_t kPositioningTimeout = 149;
}  // namespace alarm

// What an alarm code means and what to do about it; a generic text for codes we don't know.
std::string_view alarm_meaning(uint8_t code) noexcept;
// Whether RESET clears it (48–99 do, digest §6).
bool alarm_resettable(uint8_t code) noexcept;

// What clears these alarms, for a message's end: "clear it with `lec reset`"
// when RESET clears every one (48–99, digest §6), otherwise which one RESET
// does not clear and that the controller's power must be cycled.
std::string alarm_clear_hint(const std::vector<uint8_t>& codes);

struct AlarmGroup {
  std::array<uint8_t, 8> codes{};
  bool empty() const noexcept;
  std::vector<uint8_t> present() const;  // the non-zero codes
  bool operator==(const AlarmGroup&) const = default;
};

struct AlarmHistory {
  static constexpr std::size_t kGroups = 16;
  static constexpr std::size_t kRegisters = 64;

  std::array<AlarmGroup, kGroups> groups{};

  // A new group becomes group 0; the oldest falls off the end.
  void push(const AlarmGroup& g) noexcept;

  std::array<uint16_t, kRegisters> to_registers() const noexcept;
  static AlarmHistory from_registers(std::span<const uint16_t> regs) noexcept;  // needs ≥ 64
  bool operator==(const AlarmHistory&) const = default;
};

}  // namespace lec6::lec
