// The store's rows to and from records: see store_sql.hpp.

#include "store_sql.hpp"

#include <limits>

namespace lec6::serve::history::store_sql {

std::string alarms_text(const std::vector<int>& codes) {
  std::string out;
  for (int c : codes) out += fmt::format("{}{}", out.empty() ? "" : " ", c);
  return out;
}

std::vector<int> alarms_of(const std::string& text) {
  std::vector<int> out;
  std::size_t i = 0;
  while (i < text.size()) {
    std::size_t used = 0;
    try {
      out.push_back(std::stoi(text.substr(i), &used));
    } catch (const std::exception&) {
      break;
    }
    i += used + 1;
  }
  return out;
}

MotionRecord record_of(const Stmt& s) {
  MotionRecord r;
  r.id = s.i64(0);
  r.start_ms = s.i64(1);
  r.axis = s.text(2);
  r.source = s.text(3);
  r.kind = s.text(4);
  if (const auto step = s.opt(5)) r.step = static_cast<int>(*step);
  r.start_mm = s.opt(6);
  r.target_mm = s.opt(7);
  r.speed_mm_s = s.opt(8);
  r.accel_mm_s2 = s.opt(9);
  r.force_pct = s.opt(10);
  r.pushing_force_pct = s.opt(11);
  r.outcome = s.text(12);
  r.busy_up_s = s.opt(13);
  r.busy_down_s = s.opt(14);
  r.inp_s = s.opt(15);
  r.duration_s = s.opt(16).value_or(std::numeric_limits<double>::quiet_NaN());
  r.settle_s = s.opt(17);
  r.peak_thrust_pct = s.opt(18);
  r.mean_thrust_pct = s.opt(19);
  r.peak_speed_mm_s = s.opt(20);
  r.overshoot_mm = s.opt(21);
  r.final_error_mm = s.opt(22);
  r.distance_mm = s.f64(23);
  r.alarms = alarms_of(s.text(24));
  r.duration_pm_s = s.opt(25);
  r.timed_by = s.text(26);
  return r;
}

Odometer odometer_of(const Stmt& s, int first) {
  Odometer o;
  o.moves = s.i64(first);
  o.distance_mm = s.f64(first + 1);
  o.motion_s = s.f64(first + 2);
  o.pushes = s.i64(first + 3);
  o.alarms = s.i64(first + 4);
  return o;
}

}  // namespace lec6::serve::history::store_sql
