#include "lec6/lec/state_data.hpp"

#include "lec6/lec/words.hpp"

namespace lec6::lec {

std::array<uint16_t, StateData::kRegisters> StateData::to_registers() const noexcept {
  return {high_word(position_001mm), low_word(position_001mm), speed_mm_s, thrust_pct,
          high_word(target_001mm),   low_word(target_001mm),   step_no};
}

StateData StateData::from_registers(std::span<const uint16_t> r) noexcept {
  StateData s;
  if (r.size() < kRegisters) return s;
  s.position_001mm = join_words(r[0], r[1]);
  s.speed_mm_s = r[2];
  s.thrust_pct = r[3];
  s.target_001mm = join_words(r[4], r[5]);
  s.step_no = r[6];
  return s;
}

}  // namespace lec6::lec
