// Calibration from a capture (include/lec6/twin/calibrate.hpp): reads the
// session the master had with the controller (starts, flag polls, position
// reads, response times) and fits the twin's parameters to it.

#include "lec6/twin/calibrate.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <variant>

#include "calibrate_fit.hpp"
#include "calibrate_session.hpp"
#include "lec6/lec/flags.hpp"
#include "lec6/sim/behaviour.hpp"
#include "lec6/sim/motion_profile.hpp"

namespace lec6::twin {
namespace {

using modbus::FunctionCode;

int64_t us(Duration d) {
  return std::chrono::duration_cast<std::chrono::microseconds>(d).count();
}

TimePoint at_us(double t_us) {
  return TimePoint{} + std::chrono::microseconds(static_cast<int64_t>(std::llround(t_us)));
}

// Fits start delay, speed, acceleration and deceleration of one move from
// `from` to `to` (mm) to the position samples (µs, mm) after `act`.
MoveFit fit_move(const std::vector<std::pair<double, double>>& samples, int64_t act, double from,
                 double to, std::optional<double> speed_guess) {
  const double distance = std::abs(to - from);
  // Speed guess: the fastest step between consecutive samples.
  double v0 = 10.0;
  for (std::size_t i = 1; i < samples.size(); ++i) {
    const double dt = (samples[i].first - samples[i - 1].first) / 1e6;
    if (dt > 0) v0 = std::max(v0, std::abs(samples[i].second - samples[i - 1].second) / dt);
  }
  if (speed_guess) v0 = std::max(v0, std::min(*speed_guess, v0 * 1.5));
  auto model = [&](const std::vector<double>& x) {
    const double t0 = static_cast<double>(act) + x[0] * 1000.0;
    const sim::MoveLimits lim{std::exp(x[1]), std::exp(x[2]), std::exp(x[3])};
    const auto p = sim::MotionProfile::plan(at_us(t0), from, 0.0, to, lim);
    double sum = 0;
    for (const auto& [t, pos] : samples) {
      const double d = p.position(at_us(t)) - pos;
      sum += d * d;
    }
    return sum;
  };
  // The first sample that moved bounds the start from above.
  double first_move_ms = 0;
  for (const auto& [t, pos] : samples) {
    if (std::abs(pos - from) >= 0.01) {
      first_move_ms = (t - static_cast<double>(act)) / 1000.0;
      break;
    }
  }
  std::vector<double> best;
  double best_value = std::numeric_limits<double>::infinity();
  for (double a0 : {v0 * 4.0, v0 * 12.0, v0 * 40.0}) {
    for (double s0 : {first_move_ms * 0.3, first_move_ms * 0.8}) {
      double value = 0;
      auto x = fit::nelder_mead(model, {s0, std::log(v0), std::log(a0), std::log(a0)},
                                {5.0, 0.2, 0.5, 0.5}, 600, &value);
      x = fit::nelder_mead(model, x, {1.0, 0.05, 0.1, 0.1}, 600, &value);  // restart: polish
      if (value < best_value) {
        best_value = value;
        best = x;
      }
    }
  }
  MoveFit m;
  m.from_mm = from;
  m.to_mm = to;
  m.start_delay_ms = best[0];
  m.speed_mm_s = std::exp(best[1]);
  m.accel_mm_s2 = std::exp(best[2]);
  m.decel_mm_s2 = std::exp(best[3]);
  m.samples = samples.size();
  m.residual_rms_mm =
      std::sqrt(best_value / static_cast<double>(std::max<std::size_t>(1, samples.size())));
  // A move too short to reach its speed says nothing about the speed.
  const double ramps =
      m.speed_mm_s * m.speed_mm_s / 2.0 * (1.0 / m.accel_mm_s2 + 1.0 / m.decel_mm_s2);
  if (ramps > distance) m.speed_mm_s = 0;
  return m;
}

std::string format_value(double v) {
  if (std::abs(v) >= 100) return fmt::format("{:.1f}", v);
  if (std::abs(v) >= 1) return fmt::format("{:.2f}", v);
  return fmt::format("{:.4f}", v);
}

}  // namespace

const FittedParameter* Calibration::find(std::string_view key) const {
  for (const auto& f : fitted)
    if (f.key == key) return &f;
  return nullptr;
}

Calibration calibrate(std::span<const Exchange> exchanges, const modbus::LineTiming& line) {
  Calibration c;
  c.line = line;
  const int64_t ts = us(line.silent_interval());
  const int64_t t0_us = us(modbus::LineTiming::kProcessing);

  // ---- response time: Td and lateness ----
  std::vector<double> td;
  std::size_t asked = 0, silent = 0;
  for (const auto& e : exchanges) {
    if (!e.query.empty() && e.query[0] == 0) continue;  // broadcast: no reply expected
    ++asked;
    auto rt = e.response_us();
    if (!rt) {
      ++silent;
      continue;
    }
    td.push_back(static_cast<double>(*rt - ts - t0_us - us(line.wire_time(e.reply->size()))) /
                 1000.0);
  }
  if (td.empty()) {
    c.undetermined.push_back("Td (line.delay_ms): no replies in the capture");
  } else {
    const double td_ms = std::max(0.0, fit::median(td));
    std::vector<double> on_time, late;
    for (double x : td) (x - td_ms > 1.0 ? late : on_time).push_back(x);
    c.fitted.push_back({"line.delay_ms", td_ms, fit::stddev(on_time), on_time.size(), "ms",
                        "median of reply end − query end − Ts − T0 (4 ms) − reply wire time"});
    c.line.delay_td = to_duration(FractionalMilliseconds(td_ms));
    if (!late.empty()) {
      for (double& x : late) x -= td_ms;
      c.fitted.push_back({"faults.delay_rate",
                          static_cast<double>(late.size()) / static_cast<double>(td.size()), 0,
                          td.size(), "", "share of replies later than Td by over 1 ms"});
      c.fitted.push_back({"faults.extra_delay_ms", fit::median(late), fit::stddev(late),
                          late.size(), "ms", "median lateness of the late replies"});
    }
    if (silent > 0 && asked > 0) {
      c.fitted.push_back({"faults.drop_rate",
                          static_cast<double>(silent) / static_cast<double>(asked), 0, asked, "",
                          "share of queries that got no reply (noise on the line counts too)"});
    }
  }

  // ---- moves ----
  const Session s = read_session(exchanges, ts);
  std::vector<double> delays, max_speed, max_accel;
  double commanded_speed_max = 0, commanded_accel_max = 0;
  struct AtTarget {
    int64_t act;
    int64_t window_end;
  };
  std::vector<AtTarget> at_target;
  std::vector<double> homing_ms, origin_speed;
  // Thrust model inputs: (|acceleration| mm/s², thrust %) at each D9003 read while moving.
  std::vector<std::pair<double, double>> thrust_points;
  for (std::size_t i = 0; i < s.starts.size(); ++i) {
    const Start& st = s.starts[i];
    const int64_t end =
        i + 1 < s.starts.size() ? s.starts[i + 1].act_us : std::numeric_limits<int64_t>::max();
    if (st.kind == StartKind::Home) {
      // Homing time: to the first BUSY 0 after BUSY 1 (bounded by the polls).
      bool seen_busy = false;
      for (const auto& b : between(s.busy, st.act_us, end)) {
        if (b.value) seen_busy = true;
        if (seen_busy && !b.value) {
          homing_ms.push_back(static_cast<double>(b.t_us - st.act_us) / 1000.0);
          break;
        }
      }
      int top = 0;
      for (const auto& v : between(s.speeds, st.act_us, end)) top = std::max(top, v.value);
      if (top > 0) origin_speed.push_back(top);
      continue;
    }
    const auto before = last_before(s.positions, st.act_us);
    const auto window = between(s.positions, st.act_us, end);
    if (!before || window.empty()) continue;
    const double from = before->value / 100.0;
    const double to = window.back().value / 100.0;
    if (std::abs(to - from) < 0.05) {
      at_target.push_back({st.act_us, end});
      continue;
    }
    std::vector<std::pair<double, double>> samples;
    for (const auto& p : window) samples.emplace_back(static_cast<double>(p.t_us), p.value / 100.0);
    if (samples.size() < 5) continue;
    MoveFit m = fit_move(samples, st.act_us, from, to, st.speed);
    m.line = st.line;
    m.operation = st.kind == StartKind::Direct ? "direct move" : "step move";
    m.commanded_speed_mm_s = st.speed;
    m.commanded_accel_mm_s2 = st.accel;
    m.commanded_decel_mm_s2 = st.decel;
    if (m.residual_rms_mm < 0.05) {
      // The fitted profile gives the acceleration at each thrust read of this move.
      const auto profile = sim::MotionProfile::plan(
          at_us(static_cast<double>(st.act_us) + m.start_delay_ms * 1000.0), from, 0.0, to,
          sim::MoveLimits{m.speed_mm_s > 0 ? m.speed_mm_s : 1e9, m.accel_mm_s2, m.decel_mm_s2});
      for (const auto& th : between(s.thrusts, st.act_us, end)) {
        const auto k = profile.at(at_us(static_cast<double>(th.t_us)));
        if (std::abs(k.velocity) > 1.0)
          thrust_points.emplace_back(std::abs(k.acceleration), th.value);
      }
      delays.push_back(m.start_delay_ms);
      if (st.speed) {
        commanded_speed_max = std::max(commanded_speed_max, *st.speed);
        if (m.speed_mm_s > 0 && m.speed_mm_s < 0.97 * *st.speed) max_speed.push_back(m.speed_mm_s);
      }
      if (st.accel && st.decel) {
        commanded_accel_max = std::max({commanded_accel_max, *st.accel, *st.decel});
        if (m.accel_mm_s2 < 0.97 * *st.accel) max_accel.push_back(m.accel_mm_s2);
        if (m.decel_mm_s2 < 0.97 * *st.decel) max_accel.push_back(m.decel_mm_s2);
      }
    }
    c.moves.push_back(m);
  }
  double busy_delay_ms = 0;
  if (!delays.empty()) {
    busy_delay_ms = std::max(0.0, fit::median(delays));
    c.fitted.push_back({"actuator.busy_delay_ms", busy_delay_ms, fit::stddev(delays), delays.size(),
                        "ms", "carriage start (motion fit) − the controller acting on the start"});
  } else {
    c.undetermined.push_back(
        "BUSY delay (actuator.busy_delay_ms): no move with enough position reads (D9000) to fit");
  }
  if (!max_speed.empty()) {
    c.fitted.push_back({"actuator.max_speed_mm_s", fit::median(max_speed), fit::stddev(max_speed),
                        max_speed.size(), "mm/s", "fitted speed of moves commanded faster"});
  } else {
    c.undetermined.push_back(
        commanded_speed_max > 0
            ? fmt::format("max speed (actuator.max_speed_mm_s): no move was limited (at least {:g} "
                          "mm/s)",
                          commanded_speed_max)
            : "max speed (actuator.max_speed_mm_s): no direct move with a known speed");
  }
  if (!max_accel.empty()) {
    c.fitted.push_back({"actuator.max_accel_mm_s2", fit::median(max_accel), fit::stddev(max_accel),
                        max_accel.size(), "mm/s²",
                        "fitted acceleration/deceleration of moves commanded harder"});
  } else {
    c.undetermined.push_back(
        commanded_accel_max > 0
            ? fmt::format("max acceleration (actuator.max_accel_mm_s2): no move was limited (at "
                          "least {:g} mm/s²)",
                          commanded_accel_max)
            : "max acceleration (actuator.max_accel_mm_s2): no direct move with a known "
              "acceleration");
  }

  // ---- thrust: D9003 = friction share + accel share × |a| / max accel (R-MOTION-THRUST) ----
  if (thrust_points.size() >= 4) {
    double n = 0, sx = 0, sy = 0, sxx = 0, sxy = 0;
    for (const auto& [x, y] : thrust_points) {
      n += 1;
      sx += x;
      sy += y;
      sxx += x * x;
      sxy += x * y;
    }
    const double den = n * sxx - sx * sx;
    if (den > 0) {
      const double slope = (n * sxy - sx * sy) / den;
      const double friction = (sy - slope * sx) / n;
      const auto* limit = c.find("actuator.max_accel_mm_s2");
      const double max_accel = limit ? limit->value : sim::ActuatorConfig{}.max_accel_mm_s2;
      double rss = 0;
      for (const auto& [x, y] : thrust_points) rss += std::pow(y - (friction + slope * x), 2);
      const double rms = std::sqrt(rss / n);
      c.fitted.push_back({"actuator.friction_thrust_pct", friction, rms, thrust_points.size(), "%",
                          "thrust (D9003) read while moving, at zero acceleration (linear fit)"});
      c.fitted.push_back(
          {"actuator.accel_thrust_pct", slope * max_accel, rms, thrust_points.size(), "%",
           limit ? "thrust per acceleration × the fitted max acceleration"
                 : "thrust per acceleration × the twin's default max acceleration (10000 mm/s², "
                   "not determined)"});
    }
  } else {
    c.undetermined.push_back(
        "thrust scale (actuator.friction_thrust_pct, accel_thrust_pct): fewer than 4 thrust reads "
        "(D9003) during fitted moves");
  }

  // ---- the shortest BUSY pulse: moves already at their target ----
  double lo = 0, hi = std::numeric_limits<double>::infinity();
  std::size_t pulses = 0;
  for (const auto& m : at_target) {
    const double rise = static_cast<double>(m.act) + busy_delay_ms * 1000.0;
    std::optional<int64_t> last_busy;
    std::optional<int64_t> fell;
    for (const auto& b : between(s.busy, m.act, m.window_end)) {
      if (b.value) {
        last_busy = b.t_us;
      } else if (last_busy) {
        fell = b.t_us;
        break;
      }
    }
    if (!last_busy || !fell) continue;
    ++pulses;
    lo = std::max(lo, (static_cast<double>(*last_busy) - rise) / 1000.0);
    hi = std::min(hi, (static_cast<double>(*fell) - rise) / 1000.0);
  }
  if (pulses > 0 && lo <= hi) {
    c.fitted.push_back({"actuator.busy_min_ms", (lo + hi) / 2.0, (hi - lo) / 2.0, pulses, "ms",
                        "BUSY pulse of moves already at their target, bounded by the polls"});
  } else {
    c.undetermined.push_back(
        at_target.empty()
            ? "shortest BUSY pulse (actuator.busy_min_ms): no move to where the axis already was"
            : "shortest BUSY pulse (actuator.busy_min_ms): BUSY never seen on a move already at "
              "its target (shorter than the poll interval, or 0)");
  }

  // ---- homing and retargets as sequences (issue 33): calibrate_sequences.cpp ----
  fit_sequences(s, c);

  // ---- homing ----
  if (!homing_ms.empty()) {
    c.fitted.push_back({"homing.time_ms", fit::median(homing_ms), fit::stddev(homing_ms),
                        homing_ms.size(), "ms",
                        "SETUP → first poll with BUSY 0 (depends on where homing started)"});
  } else {
    c.undetermined.push_back("homing time: no return to origin with BUSY polls");
  }
  if (!origin_speed.empty()) {
    c.fitted.push_back({"actuator.origin_speed_mm_s", fit::median(origin_speed),
                        fit::stddev(origin_speed), origin_speed.size(), "mm/s",
                        "top speed (D9002) read during return to origin"});
  } else if (!c.find("actuator.origin_speed_mm_s")) {
    c.undetermined.push_back(
        "origin speed (actuator.origin_speed_mm_s): no speed (D9002) or position (D9000) reads "
        "during return to origin");
  }
  return c;
}

std::string Calibration::profile_yaml(const std::string& name, const std::string& source) const {
  std::string out = fmt::format(
      "# Fitted by `lec sim --calibrate` to {} (residuals and what could not be\n"
      "# determined: the command's stderr). Load with `lec sim --profile FILE`.\n"
      "name: {}\ndescription: calibrated from {}\n",
      source, name, source);
  for (const char* section : {"actuator", "line", "faults"}) {
    std::string body;
    if (std::string_view(section) == "line") {
      body += fmt::format("  baud: {}\n  silent_interval: {}\n", line.baud, line.silent_interval_k);
    }
    for (const auto& f : fitted) {
      if (f.key.rfind(std::string(section) + ".", 0) != 0) continue;
      body += fmt::format("  {}: {}  # ±{} {}, {} samples\n", f.key.substr(f.key.find('.') + 1),
                          format_value(f.value), format_value(f.spread), f.unit, f.samples);
    }
    for (const auto& b : chosen) {
      if (b.key.rfind(std::string(section) + ".", 0) != 0) continue;
      body += fmt::format("  {}: {}  # {} sequences: {}\n", b.key.substr(b.key.find('.') + 1),
                          b.value, b.samples, b.note);
    }
    if (!body.empty()) out += fmt::format("{}:\n{}", section, body);
  }
  return out;
}

std::string Calibration::summary() const {
  std::string out = "fitted:\n";
  for (const auto& f : fitted) {
    out += fmt::format("  {} = {} ±{} {} ({} samples; {})\n", f.key, format_value(f.value),
                       format_value(f.spread), f.unit, f.samples, f.note);
  }
  for (const auto& b : chosen)
    out += fmt::format("  {} = {} ({} sequences; {})\n", b.key, b.value, b.samples, b.note);
  if (!moves.empty()) out += "moves (motion fit to the position reads):\n";
  for (const auto& m : moves) {
    out += fmt::format(
        "  line {}: {} {:.2f} → {:.2f} mm: start {:+.1f} ms, speed {}, accel {:.0f}, decel {:.0f} "
        "mm/s²{}; residual {:.3f} mm rms over {} reads\n",
        m.line, m.operation, m.from_mm, m.to_mm, m.start_delay_ms,
        m.speed_mm_s > 0 ? fmt::format("{:.1f} mm/s", m.speed_mm_s) : std::string("not reached"),
        m.accel_mm_s2, m.decel_mm_s2,
        m.commanded_speed_mm_s
            ? fmt::format(" (commanded {:g} mm/s, {:g}/{:g} mm/s²)", *m.commanded_speed_mm_s,
                          m.commanded_accel_mm_s2.value_or(0), m.commanded_decel_mm_s2.value_or(0))
            : std::string(),
        m.residual_rms_mm, m.samples);
  }
  if (!undetermined.empty()) out += "could not determine:\n";
  for (const auto& u : undetermined) out += "  " + u + "\n";
  return out;
}

}  // namespace lec6::twin
