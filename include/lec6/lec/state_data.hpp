#pragma once
// State data D9000–D9006 (manual §10.1): where the actuator is and what it does.
//
// Thread safety: value types and pure functions; const objects may be shared between threads,
// writes need the caller's synchronisation.

#include <array>
#include <cstdint>
#include <span>

namespace lec6::lec {

struct StateData {
  static constexpr std::size_t kRegisters = 7;

  int32_t position_001mm = 0;  // D9000–D9001 current position
  uint16_t speed_mm_s = 0;     // D9002 current speed
  uint16_t thrust_pct = 0;     // D9003 current thrust
  int32_t target_001mm = 0;    // D9004–D9005 target position
  uint16_t step_no = 0;        // D9006 step completed or driving

  std::array<uint16_t, kRegisters> to_registers() const noexcept;
  static StateData from_registers(std::span<const uint16_t> regs) noexcept;  // needs ≥ 7
  bool operator==(const StateData&) const = default;
};

}  // namespace lec6::lec
