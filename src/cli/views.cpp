#include "cli/views.hpp"

#include <fmt/format.h>

#include "cli/app.hpp"
#include "lec6/lec/units.hpp"

namespace lec6::cli {

nlohmann::json flags_json(const lec::StatusFlags& f) {
  return {{"busy", f.busy()},   {"svre", f.svre()},   {"seton", f.seton()},
          {"inp", f.inp()},     {"area", f.area()},   {"warea", f.warea()},
          {"estop", f.estop()}, {"alarm", f.alarm()}, {"out", f.out()}};
}

nlohmann::json state_json(const lec::StateData& s, const lec::StatusFlags& f,
                          const std::vector<uint8_t>& alarms) {
  nlohmann::json j;
  j["position_mm"] = mm_json(s.position_001mm);
  j["speed_mm_s"] = s.speed_mm_s;
  j["thrust_pct"] = s.thrust_pct;
  j["target_mm"] = mm_json(s.target_001mm);
  j["step"] = s.step_no;
  j["flags"] = flags_json(f);
  j["alarms"] = alarms;
  return j;
}

std::string progress_line(const lec::StateData& s, const lec::StatusFlags& f) {
  return fmt::format("{:>10} mm {:>6} mm/s  thrust {:>3} %  {}", lec::format_mm(s.position_001mm),
                     s.speed_mm_s, s.thrust_pct, f.describe());
}

nlohmann::json alarm_json(uint8_t code) {
  return {{"code", code},
          {"meaning", std::string(lec::alarm_meaning(code))},
          {"resettable", lec::alarm_resettable(code)}};
}

}  // namespace lec6::cli
