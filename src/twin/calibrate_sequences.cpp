// Calibration of the assumptions a single move cannot show (issue 33,
// docs/twin-fidelity.md section A): the homing speed from positions, the
// homing direction, SETON during a re-home, and how a retarget moves the axis.

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "calibrate_fit.hpp"
#include "calibrate_session.hpp"

namespace lec6::twin {
namespace {

struct Velocity {
  int64_t t_us = 0;
  double mm_s = 0;  // signed
};

// Velocities between consecutive position reads in [from, to).
std::vector<Velocity> velocities(const Session& s, int64_t from, int64_t to) {
  std::vector<Velocity> out;
  const auto p = between(s.positions, from, to);
  for (std::size_t i = 1; i < p.size(); ++i) {
    const double dt = static_cast<double>(p[i].t_us - p[i - 1].t_us) / 1e6;
    if (dt <= 0) continue;
    out.push_back({(p[i].t_us + p[i - 1].t_us) / 2, (p[i].value - p[i - 1].value) / 100.0 / dt});
  }
  return out;
}

// The speeds (mm/s, ≥ 0) the carriage had in [from, to): D9002 when read, else
// from the position reads.
std::vector<Velocity> speeds(const Session& s, int64_t from, int64_t to) {
  std::vector<Velocity> out;
  for (const auto& v : between(s.speeds, from, to)) out.push_back({v.t_us, double(v.value)});
  if (out.size() >= 3) return out;
  out = velocities(s, from, to);
  for (auto& v : out) v.mm_s = std::abs(v.mm_s);
  return out;
}

int64_t end_of(const Session& s, std::size_t i) {
  return i + 1 < s.starts.size() ? s.starts[i + 1].act_us : std::numeric_limits<int64_t>::max();
}

void homing(const Session& s, Calibration& c) {
  std::vector<double> speed_from_positions;
  std::size_t to_min = 0, to_max = 0, kept = 0, cleared = 0;
  bool any_d9002 = false;
  for (std::size_t i = 0; i < s.starts.size(); ++i) {
    const Start& st = s.starts[i];
    if (st.kind != StartKind::Home) continue;
    const int64_t end = end_of(s, i);
    any_d9002 = any_d9002 || !between(s.speeds, st.act_us, end).empty();
    // Direction: the sign of the first clear movement. Speed: the moves in that
    // direction (the position := 0 jump at the end and the way back to the
    // origin after the far end go the other way, or are far faster: left out).
    const auto v = velocities(s, st.act_us, end);
    int dir = 0;
    for (const auto& x : v) {
      if (std::abs(x.mm_s) > 1.0) {
        dir = x.mm_s > 0 ? 1 : -1;
        break;
      }
    }
    if (dir != 0) {
      (dir < 0 ? to_min : to_max)++;
      std::vector<double> same;
      for (const auto& x : v)
        if (x.mm_s * dir > 1.0) same.push_back(std::abs(x.mm_s));
      if (same.size() >= 3) {
        const double typical = fit::median(same);
        double top = 0;
        for (double x : same)
          if (x < 3 * typical) top = std::max(top, x);
        speed_from_positions.push_back(top);
      }
    }
    // SETON while this homing runs, if the axis was homed before it (a re-home):
    // the FC02 polls that show BUSY = 1 show SETON at the same instant.
    const auto before = last_before(s.seton, st.act_us);
    if (!before || !before->value) continue;
    const auto busy = between(s.busy, st.act_us, end);
    const auto seton = between(s.seton, st.act_us, end);
    std::optional<bool> seen;
    for (const auto& b : busy) {
      if (!b.value) {
        if (seen) break;  // the end of this homing
        continue;
      }
      for (const auto& x : seton)
        if (x.t_us == b.t_us) seen = seen.value_or(true) && x.value;
    }
    if (seen) (*seen ? kept : cleared)++;
  }
  if (!any_d9002 && !speed_from_positions.empty()) {
    c.fitted.push_back({"actuator.origin_speed_mm_s", fit::median(speed_from_positions),
                        fit::stddev(speed_from_positions), speed_from_positions.size(), "mm/s",
                        "top speed from the position reads (D9000) during return to origin"});
  }
  if (to_min + to_max > 0) {
    c.chosen.push_back({"actuator.homing_direction", to_max > to_min ? "max_end" : "min_end",
                        to_min + to_max,
                        fmt::format("first movement of the homing: {} toward min, {} toward max",
                                    to_min, to_max)});
  } else {
    c.undetermined.push_back(
        "homing direction (actuator.homing_direction): no position reads (D9000) during a "
        "return to origin");
  }
  if (kept + cleared > 0) {
    c.chosen.push_back({"actuator.seton_on_rehome", cleared > 0 ? "clear" : "keep", kept + cleared,
                        fmt::format("SETON read while a re-home ran with BUSY = 1: {} kept, {} "
                                    "fell",
                                    kept, cleared)});
  } else {
    c.undetermined.push_back(
        "SETON on a re-home (actuator.seton_on_rehome): no return to origin of a homed axis with "
        "flag polls (X40-X4F) while BUSY = 1");
  }
}

// A direct ABS start while the carriage moves, to a target ahead of it: did
// the speed fall toward rest and rise again (stop_then_start), or not (replan)?
void retargets(const Session& s, Calibration& c) {
  std::size_t replan = 0, stops = 0;
  for (std::size_t i = 1; i < s.starts.size(); ++i) {
    const Start& st = s.starts[i];
    if (st.kind != StartKind::Direct || !st.target_mm) continue;
    const auto v_before = velocities(s, s.starts[i - 1].act_us, st.act_us);
    const auto here = last_before(s.positions, st.act_us);
    if (v_before.empty() || !here) continue;
    const double v0 = v_before.back().mm_s;
    if (std::abs(v0) < 5.0) continue;  // not moving: a plain start
    const double ahead = *st.target_mm - here->value / 100.0;
    if (ahead * v0 <= 0) continue;  // a reversal passes through rest either way
    const auto after = speeds(s, st.act_us, end_of(s, i));
    // Came to rest first: the speed fell below half of what it was and rose
    // again by a third of it (a re-plan toward a target further on never
    // slows; the last start's own stop at its target does not rise again).
    double low = std::abs(v0);
    bool rose_again = false;
    for (const auto& x : after) {
      low = std::min(low, x.mm_s);
      if (low < 0.5 * std::abs(v0) && x.mm_s > low + 0.3 * std::abs(v0)) rose_again = true;
    }
    if (after.size() < 3) continue;
    (rose_again ? stops : replan)++;
  }
  if (replan + stops > 0) {
    c.chosen.push_back({"actuator.retarget", stops > replan ? "stop_then_start" : "replan",
                        replan + stops,
                        fmt::format("starts while moving: {} went on smoothly, {} came to rest "
                                    "first",
                                    replan, stops)});
  } else {
    c.undetermined.push_back(
        "retarget (actuator.retarget): no direct ABS start while the axis moved the same way, "
        "with position or speed reads after it");
  }
}

}  // namespace

void fit_sequences(const Session& s, Calibration& c) {
  homing(s, c);
  retargets(s, c);
}

}  // namespace lec6::twin
