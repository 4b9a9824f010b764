#include "lec6/client/interrupt.hpp"

#include <algorithm>
#include <utility>
#include <variant>

#include "lec6/lec/flags.hpp"

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

}  // namespace

bool stops_or_releases(const modbus::Request& request) noexcept {
  if (const auto* w = std::get_if<modbus::WriteCoilRequest>(&request)) {
    // Any other value is refused by the controller (exception 03): it does nothing.
    if (w->value != modbus::kCoilOn && w->value != modbus::kCoilOff) return false;
    return stops(1, [&](std::size_t) { return std::pair<uint16_t, bool>{w->coil, w->on()}; });
  }
  if (const auto* w = std::get_if<modbus::WriteCoilsRequest>(&request)) {
    const std::size_t count = std::min<std::size_t>(w->count, w->packed.size() * 8);
    return stops(count, [&](std::size_t i) {
      return std::pair<uint16_t, bool>{static_cast<uint16_t>(w->start + i), w->bit(i)};
    });
  }
  return false;
}

}  // namespace lec6::client
