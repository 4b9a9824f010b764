#pragma once
// The odometer of an axis (docs/history.md): what it has done since it was
// first seen, persistent across restarts (the store writes it in the same
// transaction as each record, so it is never more than the record in flight
// behind). Service thresholds ("lubricate every 2000 km") raise a notice
// once the odometer passes the next multiple since the last service.
//
// Thread safety: plain values.

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "motion_record.hpp"

namespace lec6::serve::history {

struct Odometer {
  int64_t moves = 0;  // every motion recorded (home, move, run-step, jog)
  double distance_mm = 0;
  double motion_s = 0;  // time in motion (BUSY up to BUSY down)
  int64_t pushes = 0;   // pushing moves (pushed or push missed)
  int64_t alarms = 0;   // motions that ended on an alarm

  void add(const MotionRecord& r);
};

// "lubricate every 2000 km": one of every_km, every_moves, every_hours.
struct ServiceThreshold {
  std::string what;
  std::optional<double> every_km;
  std::optional<double> every_moves;
  std::optional<double> every_hours;
};

// A service due: the odometer is past the first multiple of the threshold
// beyond the last service (`done`: the odometer then, zero when never).
struct ServiceNotice {
  std::string what;
  std::string message;  // "lubricate: 2013 km travelled since the last service (every 2000 km)"
};
std::vector<ServiceNotice> notices(const Odometer& now, const Odometer& done,
                                   const std::vector<ServiceThreshold>& thresholds);

nlohmann::json to_json(const Odometer& o);

}  // namespace lec6::serve::history
