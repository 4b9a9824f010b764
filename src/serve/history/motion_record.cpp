#include "motion_record.hpp"

#include <fmt/format.h>

#include <chrono>
#include <cmath>
#include <ctime>

#include <nlohmann/json.hpp>

namespace lec6::serve::history {
namespace {

using nlohmann::json;

json opt(const std::optional<double>& v) {
  return v ? json(*v) : json(nullptr);
}

std::string csv_opt(const std::optional<double>& v) {
  return v ? fmt::format("{:g}", *v) : std::string();
}

// A CSV field: quoted when it holds a comma, a quote or a line break.
std::string csv_text(const std::string& s) {
  if (s.find_first_of(",\"\r\n") == std::string::npos) return s;
  std::string out = "\"";
  for (char c : s) {
    if (c == '"') out += '"';
    out += c;
  }
  return out + '"';
}

}  // namespace

std::string iso_time(int64_t unix_ms) {
  const std::time_t secs = static_cast<std::time_t>(unix_ms / 1000);
  std::tm tm{};
  gmtime_r(&secs, &tm);
  return fmt::format("{:04}-{:02}-{:02}T{:02}:{:02}:{:02}.{:03}Z", tm.tm_year + 1900, tm.tm_mon + 1,
                     tm.tm_mday, tm.tm_hour, tm.tm_min, tm.tm_sec, unix_ms % 1000);
}

json to_json(const MotionRecord& r) {
  return {{"id", r.id},
          {"start", iso_time(r.start_ms)},
          {"start_ms", r.start_ms},
          {"axis", r.axis},
          {"source", r.source},
          {"kind", r.kind},
          {"step", r.step ? json(*r.step) : json(nullptr)},
          {"start_mm", opt(r.start_mm)},
          {"target_mm", opt(r.target_mm)},
          {"speed_mm_s", opt(r.speed_mm_s)},
          {"accel_mm_s2", opt(r.accel_mm_s2)},
          {"force_pct", opt(r.force_pct)},
          {"pushing_force_pct", opt(r.pushing_force_pct)},
          {"outcome", r.outcome},
          {"timeline",
           {{"busy_up_s", opt(r.busy_up_s)},
            {"busy_down_s", opt(r.busy_down_s)},
            {"inp_s", opt(r.inp_s)}}},
          {"duration_s",
           std::isnan(r.duration_s) ? nlohmann::json(nullptr) : nlohmann::json(r.duration_s)},
          {"duration_pm_s", opt(r.duration_pm_s)},
          {"timed_by", r.timed_by.empty() ? nlohmann::json(nullptr) : nlohmann::json(r.timed_by)},
          {"settle_s", opt(r.settle_s)},
          {"peak_thrust_pct", opt(r.peak_thrust_pct)},
          {"mean_thrust_pct", opt(r.mean_thrust_pct)},
          {"peak_speed_mm_s", opt(r.peak_speed_mm_s)},
          {"overshoot_mm", opt(r.overshoot_mm)},
          {"final_error_mm", opt(r.final_error_mm)},
          {"distance_mm", r.distance_mm},
          {"alarms", r.alarms}};
}

std::string csv_header() {
  return "id,start,axis,source,kind,step,start_mm,target_mm,speed_mm_s,accel_mm_s2,force_pct,"
         "pushing_force_pct,outcome,busy_up_s,busy_down_s,inp_s,duration_s,settle_s,"
         "peak_thrust_pct,mean_thrust_pct,peak_speed_mm_s,overshoot_mm,final_error_mm,"
         "distance_mm,alarms,duration_pm_s,timed_by\r\n";
}

std::string csv_row(const MotionRecord& r) {
  std::string alarms;
  for (int a : r.alarms) alarms += fmt::format("{}{}", alarms.empty() ? "" : " ", a);
  return fmt::format(
      "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{:g},{},{},{}\r\n",
      r.id, iso_time(r.start_ms), csv_text(r.axis), csv_text(r.source), r.kind,
      r.step ? std::to_string(*r.step) : "", csv_opt(r.start_mm), csv_opt(r.target_mm),
      csv_opt(r.speed_mm_s), csv_opt(r.accel_mm_s2), csv_opt(r.force_pct),
      csv_opt(r.pushing_force_pct), r.outcome, csv_opt(r.busy_up_s), csv_opt(r.busy_down_s),
      csv_opt(r.inp_s),
      csv_opt(std::isnan(r.duration_s) ? std::nullopt : std::optional<double>(r.duration_s)),
      csv_opt(r.settle_s), csv_opt(r.peak_thrust_pct), csv_opt(r.mean_thrust_pct),
      csv_opt(r.peak_speed_mm_s), csv_opt(r.overshoot_mm), csv_opt(r.final_error_mm), r.distance_mm,
      alarms, csv_opt(r.duration_pm_s), r.timed_by);
}

int64_t system_ms() {
  return std::chrono::duration_cast<std::chrono::milliseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

}  // namespace lec6::serve::history
