#include "lec6/lec/state_data.hpp"

namespace lec6::lec {
namespace {
int32_t join(uint16_t h, uint16_t l) { return static_cast<int32_t>((static_cast<uint32_t>(h) << 16) | l); }
uint16_t hi(int32_t v) { return static_cast<uint16_t>(static_cast<uint32_t>(v) >> 16); }
uint16_t lo(int32_t v) { return static_cast<uint16_t>(static_cast<uint32_t>(v) & 0xFFFF); }
}  // namespace

std::array<uint16_t, StateData::kRegisters> StateData::to_registers() const noexcept {
  return {hi(position_001mm), lo(position_001mm), speed_mm_s, thrust_pct,
          hi(target_001mm),   lo(target_001mm),   step_no};
}

StateData StateData::from_registers(std::span<const uint16_t> r) noexcept {
  StateData s;
  if (r.size() < kRegisters) return s;
  s.position_001mm = join(r[0], r[1]);
  s.speed_mm_s = r[2];
  s.thrust_pct = r[3];
  s.target_001mm = join(r[4], r[5]);
  s.step_no = r[6];
  return s;
}

}  // namespace lec6::lec
