#include "lec6/client/interrupt.hpp"

#include <variant>

#include "lec6/lec/flags.hpp"

namespace lec6::client {

bool stops_or_releases(const modbus::Request& request) noexcept {
  const auto* w = std::get_if<modbus::WriteCoilRequest>(&request);
  if (!w) return false;
  using lec::Coil;
  const auto is = [&](Coil c) { return w->coil == lec::address(c); };
  if (is(Coil::RESET)) return true;
  if (is(Coil::HOLD)) return w->on();
  const bool release = w->value == modbus::kCoilOff;
  return release && (is(Coil::SVON) || is(Coil::DRIVE) || is(Coil::SETUP) || is(Coil::JOG_MINUS) ||
                     is(Coil::JOG_PLUS));
}

}  // namespace lec6::client
