// A program using the twin through find_package(lec6): lec6::sim. One
// simulated controller, driven by Modbus requests as a master would (the
// manual's operation example 2, direct operation), on its own time points.
#include <chrono>
#include <cstdio>

#include "lec6/lec/flags.hpp"
#include "lec6/lec/memory_map.hpp"
#include "lec6/lec/step_data.hpp"
#include "lec6/sim/controller.hpp"

using namespace lec6;
using namespace std::chrono_literals;

int main() {
  sim::Controller twin;
  TimePoint t{};
  auto coil = [&](lec::Coil c, bool on) {
    (void)twin.handle(modbus::WriteCoilRequest{lec::address(c), on ? modbus::kCoilOn : uint16_t{0}},
                      t);
  };
  coil(lec::Coil::SerialMode, true);
  coil(lec::Coil::SVON, true);
  t += 1s;
  coil(lec::Coil::SETUP, true);  // return to origin
  t += 10s;
  coil(lec::Coil::SETUP, false);

  lec::StepData move;
  move.movement_mode = lec::MovementMode::Absolute;
  move.speed_mm_s = 200;
  move.position_001mm = 5000;  // 50.00 mm
  move.acceleration_mm_s2 = move.deceleration_mm_s2 = 1000;
  move.pushing_speed_mm_s = 20;  // unused when positioning, but must be valid
  move.moving_force_pct = 100;
  move.in_position_001mm = 10;
  const auto regs = move.to_registers();
  (void)twin.handle(modbus::WriteRegistersRequest::of(lec::kDirectData, regs), t);
  const uint16_t start = lec::kDirectStartValue;
  (void)twin.handle(modbus::WriteRegistersRequest::of(lec::kDirectStart, std::span(&start, 1)), t);
  t += 2s;

  const lec::StatusFlags flags = twin.status(t);
  std::printf("position %.2f mm, INP %d, BUSY %d\n", twin.position_mm(t),
              flags.test(lec::StatusFlags::Inp), flags.test(lec::StatusFlags::Busy));
  return flags.test(lec::StatusFlags::Inp) ? 0 : 1;
}
