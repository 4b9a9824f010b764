#pragma once
// One motion as lec serve's history keeps it (docs/history.md): what was
// asked, who asked, how it ended, and what the telemetry saw during it.
// Private to serve/history.
//
// Thread safety: plain values.

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

namespace lec6::serve::history {

struct MotionRecord {
  int64_t id = 0;        // increasing, unique in one database
  int64_t start_ms = 0;  // wall clock, Unix milliseconds, when the motion started
  std::string axis;
  std::string source;  // "http 127.0.0.1", "mqtt", "telemetry" (another master or Modbus TCP)
  std::string kind;    // home, move, run-step, jog
  std::optional<int> step;
  std::optional<double> start_mm;  // where the carriage was when it started
  std::optional<double> target_mm;
  std::optional<double>
      speed_mm_s;  // settings asked (direct moves); nullopt: the step's or unknown
  std::optional<double> accel_mm_s2;
  std::optional<double> force_pct;  // moving force
  std::optional<double> pushing_force_pct;
  // reached, pushed, push_missed, stopped, alarm, deadline, not_started;
  // refused: nothing that could move the axis reached the wire (servo off, a
  // soft limit, an alarm already active): kept as an event, not a motion
  // (the odometer and the drift detector skip it; tracker_test.cpp
  // ARefusedMoveIsAnEventNotAMotion).
  std::string outcome;
  std::optional<double> busy_up_s, busy_down_s, inp_s;  // the timeline, from the start
  // BUSY's rise to its fall, each edge dated at the middle of the two polls
  // that bracket it, ± duration_pm_s (issue 32); NaN: BUSY was never seen, no
  // duration (JSON null). Records of older versions: start to BUSY down.
  double duration_s = 0;
  std::optional<double> duration_pm_s;
  // How the duration was dated: "polls" (the BUSY brackets' middles) or
  // "positions" (the position samples against the move's profile,
  // profile_fit.hpp: narrower where the line is busy). Empty: no duration.
  std::string timed_by;
  std::optional<double> settle_s;  // BUSY down to INP
  std::optional<double> peak_thrust_pct, mean_thrust_pct, peak_speed_mm_s;
  std::optional<double> overshoot_mm;    // past the target, in the direction of travel
  std::optional<double> final_error_mm;  // final position − target
  double distance_mm = 0;                // travelled, as the samples saw it
  std::vector<int> alarms;               // alarm codes raised

  bool succeeded() const { return outcome == "reached" || outcome == "pushed"; }
  bool refused() const { return outcome == "refused"; }
};

nlohmann::json to_json(const MotionRecord& r);
// The CSV header and one row per record (the same columns as to_json's keys).
std::string csv_header();
std::string csv_row(const MotionRecord& r);
// "2026-11-24T19:04:44.123Z"
std::string iso_time(int64_t unix_ms);

// The wall clock now, Unix milliseconds (records' times; the default clock of
// the store and the history).
int64_t system_ms();

}  // namespace lec6::serve::history
