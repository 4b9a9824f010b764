// The twin's two named configurations (behaviour.hpp): the manual's ideal and
// the default twin, which follows the field evidence where it is strong enough
// (docs/protocol-decisions.md, "The default twin"; rows of docs/twin-fidelity.md).

#include <chrono>

#include "lec6/sim/behaviour.hpp"

namespace lec6::sim {

ActuatorConfig ideal_config() {
  return ActuatorConfig{};
}

ActuatorConfig default_config() {
  using std::chrono::milliseconds;
  ActuatorConfig c = ideal_config();
  // Field (issue 12, R-FLAG-BUSY-START, R-FLAG-BUSY-MIN): BUSY rises ~20 ms
  // after the start was taken; a move already at its target shows a 60 ms pulse.
  c.busy_delay = milliseconds(20);
  c.busy_min = milliseconds(60);
  // Field drivers (issue 33, R-MOTION-HOMING): written on hardware, they allow
  // ~10 s for SETON from a cold start anywhere on a 450 mm stroke: ≥ 45 mm/s.
  c.origin_speed_mm_s = 50.0;
  // Field driver (issue 33, R-FLAG-SETON-REHOME): its wait for SETON after a
  // second SETUP, then RESET, works on hardware only if SETON falls while the
  // re-home runs.
  c.seton_on_rehome = ActuatorConfig::SetonOnRehome::Clear;
  return c;
}

}  // namespace lec6::sim
