#include "motion_settings.hpp"

namespace lec6::serve::history {

nlohmann::json motion_settings(const Command& cmd) {
  nlohmann::json j = nlohmann::json::object();
  if (cmd.op == Op::RunStep && cmd.step) j["step"] = *cmd.step;
  if (cmd.op != Op::Move) return j;
  const client::DirectMove& m = cmd.move;
  if (m.position_001mm && !m.relative) j["target_mm"] = *m.position_001mm / 100.0;
  if (m.speed_mm_s) j["speed_mm_s"] = *m.speed_mm_s;
  if (m.acceleration_mm_s2) j["acceleration_mm_s2"] = *m.acceleration_mm_s2;
  if (m.moving_force_pct) j["moving_force_pct"] = *m.moving_force_pct;
  if (m.pushing_force_pct) j["pushing_force_pct"] = *m.pushing_force_pct;
  return j;
}

}  // namespace lec6::serve::history
