#include "lec6/lec/step_defaults.hpp"

namespace lec6::lec {

StepData default_step_data() {
  StepData d;
  d.movement_mode = MovementMode::Absolute;
  d.speed_mm_s = 100;
  d.acceleration_mm_s2 = 1000;
  d.deceleration_mm_s2 = 1000;
  d.pushing_force_pct = 0;
  d.trigger_level_pct = 0;
  d.pushing_speed_mm_s = 20;
  d.moving_force_pct = 100;
  d.in_position_001mm = 50;  // 0.50 mm
  return d;
}

}  // namespace lec6::lec
