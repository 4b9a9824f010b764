#include "lec6/lec/alarms.hpp"

#include <fmt/format.h>

#include <algorithm>

namespace lec6::lec {

std::string_view alarm_meaning(uint8_t code) noexcept {
  switch (code) {
    case alarm::kInvalidData:
      return "invalid step or operation data: a value is outside its range (check the step with "
             "`lec step get`)";
    case alarm::kStepNotRegistered:
      return "step data not registered: the selected step is blank";
    case alarm::kStepBeyondStroke:
      return "step target beyond the stroke: the position is outside the actuator's stroke";
    case alarm::kDirectBeyondStroke:
      return "direct operation target beyond the stroke";
    case alarm::kOriginTimeout:
      return "return to origin did not complete in time";
    case alarm::kServoOff:
      return "operation started while the servo is off (run `lec servo on`)";
    case alarm::kNotHomed:
      return "operation started before return to origin (run `lec home`)";
    case alarm::kPositioningTimeout:
      return "positioning did not complete in time";
    default:
      return "alarm (see the controller's operation manual for this code)";
  }
}

bool alarm_resettable(uint8_t code) noexcept {
  return code >= 48 && code <= 99;
}

std::string alarm_clear_hint(const std::vector<uint8_t>& codes) {
  for (uint8_t c : codes) {
    if (!alarm_resettable(c)) {
      return fmt::format(
          "RESET does not clear alarm {} (only 48-99): switch the controller's power off and on",
          c);
    }
  }
  return "clear it with `lec reset`";
}

bool AlarmGroup::empty() const noexcept {
  return std::all_of(codes.begin(), codes.end(), [](uint8_t c) { return c == 0; });
}

std::vector<uint8_t> AlarmGroup::present() const {
  std::vector<uint8_t> out;
  for (uint8_t c : codes) {
    if (c) out.push_back(c);
  }
  return out;
}

void AlarmHistory::push(const AlarmGroup& g) noexcept {
  std::move_backward(groups.begin(), groups.end() - 1, groups.end());
  groups[0] = g;
}

std::array<uint16_t, AlarmHistory::kRegisters> AlarmHistory::to_registers() const noexcept {
  std::array<uint16_t, kRegisters> regs{};
  for (std::size_t g = 0; g < kGroups; ++g) {
    for (std::size_t i = 0; i < 8; i += 2) {
      regs[g * 4 + i / 2] =
          static_cast<uint16_t>((groups[g].codes[i] << 8) | groups[g].codes[i + 1]);
    }
  }
  return regs;
}

AlarmHistory AlarmHistory::from_registers(std::span<const uint16_t> regs) noexcept {
  AlarmHistory h;
  for (std::size_t r = 0; r < std::min(regs.size(), kRegisters); ++r) {
    h.groups[r / 4].codes[(r % 4) * 2] = static_cast<uint8_t>(regs[r] >> 8);
    h.groups[r / 4].codes[(r % 4) * 2 + 1] = static_cast<uint8_t>(regs[r] & 0xFF);
  }
  return h;
}

}  // namespace lec6::lec
