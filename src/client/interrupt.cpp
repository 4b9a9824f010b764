#include "lec6/client/interrupt.hpp"

#include <algorithm>
#include <array>
#include <utility>
#include <variant>

#include "lec6/lec/flags.hpp"
#include "lec6/lec/memory_map.hpp"

namespace lec6::client {
namespace {

using lec::Coil;

// What writing one coil at one level does to motion.
enum class Effect { None, HardStop, Release, Starts };

Effect effect(uint16_t coil, bool on) noexcept {
  switch (static_cast<Coil>(coil)) {
    case Coil::RESET:
      return on ? Effect::HardStop : Effect::Release;  // both levels: the pulse's two halves
    case Coil::HOLD:
      return on ? Effect::HardStop : Effect::Starts;  // HOLD off resumes a held operation
    case Coil::SVON:
      return on ? Effect::Starts : Effect::HardStop;  // servo off: nothing can move
    case Coil::DRIVE:
    case Coil::SETUP:
    case Coil::JOG_MINUS:
    case Coil::JOG_PLUS:
      return on ? Effect::Starts : Effect::Release;
    default:
      return Effect::None;  // IN0–IN5 select a step; Y30 the input mode
  }
}

// A write of coil levels: a stop when one of them stops (RESET ← 1, HOLD ← 1,
// SVON ← 0), or when every level that matters releases and none starts.
template <typename Levels>
bool stops(std::size_t count, Levels level) noexcept {
  bool release = false;
  bool starts = false;
  for (std::size_t i = 0; i < count; ++i) {
    const auto [coil, on] = level(i);
    switch (effect(coil, on)) {
      case Effect::HardStop:
        return true;
      case Effect::Release:
        release = true;
        break;
      case Effect::Starts:
        starts = true;
        break;
      case Effect::None:
        break;
    }
  }
  return release && !starts;
}

// Calls `judge(count, level)` with the coil levels a write sets (FC05,
// FC0F, FC10 to the control words); false for every other request.
template <typename Judge>
bool judge_levels(const modbus::Request& request, Judge judge) noexcept {
  if (const auto* w = std::get_if<modbus::WriteCoilRequest>(&request)) {
    // Any other value is refused by the controller (exception 03): it does nothing.
    if (w->value != modbus::kCoilOn && w->value != modbus::kCoilOff) return false;
    return judge(1, [&](std::size_t) { return std::pair<uint16_t, bool>{w->coil, w->on()}; });
  }
  if (const auto* w = std::get_if<modbus::WriteCoilsRequest>(&request)) {
    const std::size_t count = std::min<std::size_t>(w->count, w->packed.size() * 8);
    return judge(count, [&](std::size_t i) {
      return std::pair<uint16_t, bool>{static_cast<uint16_t>(w->start + i), w->bit(i)};
    });
  }
  if (const auto* w = std::get_if<modbus::WriteRegistersRequest>(&request)) {
    // The control words: D90C1 is Y10-Y1F as one word (bit 0 = Y10), D90C2
    // Y30-Y3F. A PLC that writes its output image as a word writes every
    // coil of it at once (issue 31: a HOLD written so is a stop too).
    // No allocation (noexcept): at most the two control words' 32 coils.
    std::array<std::pair<uint16_t, bool>, 32> levels{};
    std::size_t n = 0;
    const std::size_t count = std::min<std::size_t>(w->count, w->data.size() / 2);
    for (std::size_t i = 0; i < count; ++i) {
      const auto address = static_cast<uint16_t>(w->start + i);
      uint16_t first_coil = 0;
      if (address == lec::kControlWordY10) {
        first_coil = 0x10;
      } else if (address == lec::kControlWordY30) {
        first_coil = 0x30;
      } else {
        continue;
      }
      const auto word = static_cast<uint16_t>((w->data[2 * i] << 8) | w->data[2 * i + 1]);
      for (uint16_t bit = 0; bit < 16 && n < levels.size(); ++bit)
        levels[n++] = {static_cast<uint16_t>(first_coil + bit), ((word >> bit) & 1U) != 0};
    }
    if (n == 0) return false;
    return judge(n, [&](std::size_t i) { return levels[i]; });
  }
  return false;
}

template <typename Levels>
bool any_effect(std::size_t count, Levels level, Effect wanted) noexcept {
  for (std::size_t i = 0; i < count; ++i) {
    const auto [coil, on] = level(i);
    if (effect(coil, on) == wanted) return true;
  }
  return false;
}

}  // namespace

bool stops_or_releases(const modbus::Request& request) noexcept {
  return judge_levels(request, [](std::size_t n, auto level) { return stops(n, level); });
}

bool stops_hard(const modbus::Request& request) noexcept {
  return judge_levels(
      request, [](std::size_t n, auto level) { return any_effect(n, level, Effect::HardStop); });
}

bool starts_motion(const modbus::Request& request) noexcept {
  if (const auto* w = std::get_if<modbus::WriteRegistersRequest>(&request)) {
    if (w->start <= lec::kDirectStart && lec::kDirectStart < w->start + w->count) return true;
  }
  return judge_levels(
      request, [](std::size_t n, auto level) { return any_effect(n, level, Effect::Starts); });
}

}  // namespace lec6::client
