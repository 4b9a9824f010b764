#include "odometer.hpp"

#include <fmt/format.h>

#include <cmath>

#include <nlohmann/json.hpp>

namespace lec6::serve::history {

void Odometer::add(const MotionRecord& r) {
  if (r.refused()) return;  // nothing reached the wire: not a motion
  ++moves;
  distance_mm += r.distance_mm;
  if (!std::isnan(r.duration_s)) motion_s += r.duration_s;
  if (r.pushing_force_pct.value_or(0) > 0 || r.outcome == "pushed" || r.outcome == "push_missed") {
    ++pushes;
  }
  if (r.outcome == "alarm" || !r.alarms.empty()) ++alarms;
}

std::vector<ServiceNotice> notices(const Odometer& now, const Odometer& done,
                                   const std::vector<ServiceThreshold>& thresholds) {
  std::vector<ServiceNotice> out;
  for (const ServiceThreshold& t : thresholds) {
    if (t.every_km && (now.distance_mm - done.distance_mm) / 1e6 >= *t.every_km) {
      out.push_back(
          {t.what, fmt::format("{}: {:.1f} km travelled since the last service (every "
                               "{:g} km)",
                               t.what, (now.distance_mm - done.distance_mm) / 1e6, *t.every_km)});
    } else if (t.every_moves && double(now.moves - done.moves) >= *t.every_moves) {
      out.push_back({t.what, fmt::format("{}: {} moves since the last service (every {:g} moves)",
                                         t.what, now.moves - done.moves, *t.every_moves)});
    } else if (t.every_hours && (now.motion_s - done.motion_s) / 3600 >= *t.every_hours) {
      out.push_back(
          {t.what, fmt::format("{}: {:.1f} h in motion since the last service (every "
                               "{:g} h)",
                               t.what, (now.motion_s - done.motion_s) / 3600, *t.every_hours)});
    }
  }
  return out;
}

nlohmann::json to_json(const Odometer& o) {
  return {{"moves", o.moves},
          {"distance_m", o.distance_mm / 1000},
          {"motion_h", o.motion_s / 3600},
          {"pushes", o.pushes},
          {"alarms", o.alarms}};
}

}  // namespace lec6::serve::history
