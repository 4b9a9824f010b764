#include "lec6/sim/motion_profile.hpp"

#include <algorithm>
#include <cmath>

namespace lec6::sim {

namespace {

constexpr double kPosEps = 1e-9;    // mm: below this two positions are the same
constexpr double kVelEps = 1e-9;    // mm/s
constexpr double kTouchEps = 1e-6;  // mm: "already at" a value when searching crossings

Duration seconds_to_duration(double s) {
  return Duration(static_cast<Duration::rep>(std::llround(s * 1e9)));
}

double duration_to_seconds(Duration d) {
  return static_cast<double>(d.count()) / 1e9;
}

// Smallest τ in [lo, hi] with c + b·τ + a/2·τ² = 0, if any.
std::optional<double> first_root(double c, double b, double a, double lo, double hi) {
  constexpr double kTol = 1e-12;
  auto in_range = [&](double t) { return t >= lo - kTol && t <= hi + kTol; };
  std::vector<double> roots;
  const double qa = 0.5 * a;
  if (std::abs(qa) < 1e-15) {
    if (std::abs(b) < 1e-15) {
      if (std::abs(c) <= kPosEps) roots.push_back(lo);
    } else {
      roots.push_back(-c / b);
    }
  } else {
    double disc = b * b - 4.0 * qa * c;
    if (disc < 0.0) {
      // Touching from one side leaves a tiny negative discriminant in floating
      // point; accept it when the vertex is within tolerance of the value.
      const double tv = -b / (2.0 * qa);
      const double cv = c + b * tv + qa * tv * tv;
      if (std::abs(cv) <= 1e-7) roots.push_back(tv);
    } else {
      const double sq = std::sqrt(disc);
      // Numerically stable pair of roots.
      const double q = -0.5 * (b + (b >= 0.0 ? sq : -sq));
      if (std::abs(q) > 0.0) {
        roots.push_back(q / qa);
        roots.push_back(c / q);
      } else {
        roots.push_back(0.0);
      }
    }
  }
  std::optional<double> best;
  for (double r : roots) {
    if (!std::isfinite(r) || !in_range(r)) continue;
    r = std::clamp(r, lo, hi);
    if (!best || r < *best) best = r;
  }
  return best;
}

}  // namespace

MotionProfile MotionProfile::hold(TimePoint t0, double position) {
  MotionProfile p;
  p.t0_ = t0;
  p.start_position_ = position;
  p.final_position_ = position;
  return p;
}

void MotionProfile::push(double duration, double a) {
  if (!(duration > 0.0)) return;
  Segment seg;
  seg.t_start = total_;
  seg.duration = duration;
  if (segments_.empty()) {
    seg.p0 = start_position_;
    seg.v0 = start_velocity_;
  } else {
    const Segment& b = segments_.back();
    seg.p0 = b.p0 + b.v0 * b.duration + 0.5 * b.a * b.duration * b.duration;
    seg.v0 = b.v0 + b.a * b.duration;
  }
  seg.a = a;
  segments_.push_back(seg);
  total_ += duration;
}

MotionProfile MotionProfile::plan(TimePoint t0, double position, double velocity, double target,
                                  const MoveLimits& limits) {
  MotionProfile prof;
  prof.t0_ = t0;
  prof.start_position_ = position;
  prof.start_velocity_ = velocity;
  const double vmax = std::max(limits.speed, 1e-9);
  const double acc = std::max(limits.acceleration, 1e-9);
  const double dec = std::max(limits.deceleration, 1e-9);

  double p = position;
  double v = velocity;
  auto advance = [&](double dt, double a) {
    prof.push(dt, a);
    p += v * dt + 0.5 * a * dt * dt;
    v += a * dt;
  };

  // At most three passes: brake a wrong-way or overshooting start to rest, then
  // one trapezoid/triangle from rest (or from a velocity toward the target).
  for (int guard = 0; guard < 4; ++guard) {
    const double d = target - p;
    if (std::abs(d) <= kPosEps && std::abs(v) <= kVelEps) break;
    const double s = d > 0.0 ? 1.0 : (d < 0.0 ? -1.0 : (v > 0.0 ? 1.0 : -1.0));
    const double dist = std::abs(d);
    const double w = s * v;  // speed toward the target (negative: away from it)
    if (w < -kVelEps) {
      advance(-w / dec, s * dec);  // brake the wrong-way motion to rest
      v = 0.0;
      continue;
    }
    const double w0 = std::max(w, 0.0);
    const double stop_dist = w0 * w0 / (2.0 * dec);
    if (stop_dist > dist + 1e-9) {
      advance(w0 / dec, -s * dec);  // cannot stop in time: brake, come back
      v = 0.0;
      continue;
    }
    if (w0 > vmax) {
      const double d1 = (w0 * w0 - vmax * vmax) / (2.0 * dec);
      const double d3 = vmax * vmax / (2.0 * dec);
      const double cruise = std::max(0.0, dist - d1 - d3);
      advance((w0 - vmax) / dec, -s * dec);
      advance(cruise / vmax, 0.0);
      advance(vmax / dec, -s * dec);
      break;
    }
    const double vpeak2 = (2.0 * acc * dec * dist + dec * w0 * w0) / (acc + dec);
    const double vp = std::min(vmax, std::sqrt(std::max(vpeak2, w0 * w0)));
    const double d1 = (vp * vp - w0 * w0) / (2.0 * acc);
    const double d3 = vp * vp / (2.0 * dec);
    const double cruise = std::max(0.0, dist - d1 - d3);
    advance((vp - w0) / acc, s * acc);
    if (vp > 0.0) advance(cruise / vp, 0.0);
    advance(vp / dec, -s * dec);
    break;
  }
  prof.final_position_ = target;
  return prof;
}

MotionProfile MotionProfile::stop(TimePoint t0, double position, double velocity,
                                  double deceleration) {
  MotionProfile prof;
  prof.t0_ = t0;
  prof.start_position_ = position;
  prof.start_velocity_ = velocity;
  const double dec = std::max(deceleration, 1e-9);
  const double dt = std::abs(velocity) / dec;
  prof.push(dt, velocity > 0.0 ? -dec : dec);
  prof.final_position_ = position + velocity * dt * 0.5;
  return prof;
}

Kinematics MotionProfile::eval(double s) const {
  if (segments_.empty() || s >= total_) return {final_position_, 0.0, 0.0};
  if (s <= 0.0) return {start_position_, start_velocity_, segments_.front().a};
  for (const Segment& seg : segments_) {
    if (s < seg.t_start + seg.duration) {
      const double tau = s - seg.t_start;
      return {seg.p0 + seg.v0 * tau + 0.5 * seg.a * tau * tau, seg.v0 + seg.a * tau, seg.a};
    }
  }
  return {final_position_, 0.0, 0.0};
}

Kinematics MotionProfile::at(TimePoint t) const {
  return eval(duration_to_seconds(t - t0_));
}

TimePoint MotionProfile::end_time() const {
  return t0_ + seconds_to_duration(total_);
}

std::optional<TimePoint> MotionProfile::first_crossing(double value, TimePoint from) const {
  const double sf = duration_to_seconds(from - t0_);
  if (std::abs(eval(std::max(sf, 0.0)).position - value) <= kTouchEps) return from;
  const double start = std::max(sf, 0.0);
  for (const Segment& seg : segments_) {
    const double seg_end = seg.t_start + seg.duration;
    if (seg_end < start) continue;
    const double lo = std::max(0.0, start - seg.t_start);
    auto r = first_root(seg.p0 - value, seg.v0, seg.a, lo, seg.duration);
    if (r) {
      const TimePoint t = t0_ + seconds_to_duration(seg.t_start + *r);
      return std::max(t, from);
    }
  }
  if (std::abs(final_position_ - value) <= 1e-6) return std::max(end_time(), from);
  return std::nullopt;
}

MotionProfile MotionProfile::halted_at(TimePoint t) const {
  const double s = duration_to_seconds(t - t0_);
  if (s >= total_) return *this;
  MotionProfile p;
  p.t0_ = t0_;
  p.start_position_ = start_position_;
  p.start_velocity_ = start_velocity_;
  if (s <= 0.0) {
    p.start_velocity_ = 0.0;
    p.final_position_ = start_position_;
    return p;
  }
  for (const Segment& seg : segments_) {
    if (seg.t_start >= s) break;
    Segment cut = seg;
    cut.duration = std::min(seg.duration, s - seg.t_start);
    p.segments_.push_back(cut);
  }
  p.total_ = s;
  p.final_position_ = eval(s).position;
  return p;
}

}  // namespace lec6::sim
