#include "profile_fit.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace lec6::serve::history {
namespace {

// A sample this close to the start or the target (mm) is at rest there, not
// moving: the controller's positions are 0.01 mm steps.
constexpr double kAtRestMm = 0.05;
// Slack added to every window: the host's time stamps around the exchange.
constexpr double kStampSlackS = 0.001;
// A position read is the carriage's to within half its 0.01 mm step.
constexpr double kPositionHalfStepMm = 0.005;
// Samples during the motion a fit needs: two always admit some speed (a
// hold between them would be read as a slower move: a reviewer's case);
// a third must agree with them.
constexpr int kMovingSamples = 3;
// Cruise speeds tried, as fractions of the speed written: the controller
// never goes faster than asked (the top allows 1 % for its own scaling), and
// an axis slower than a quarter of it is not judged by this fit.
constexpr double kFastest = 1.01, kSlowest = 0.25;
constexpr int kSpeeds = 1500;

// The trapezoid at cruise speed v over distance D (triangular when D is too
// short to reach v).
struct Shape {
  double vp = 0, sa = 0, sd = 0, length_s = 0;
};

Shape shape(double D, double v, double a, double d) {
  Shape s;
  s.vp = std::min(v, std::sqrt(2 * D * a * d / (a + d)));
  s.sa = s.vp * s.vp / (2 * a);
  s.sd = s.vp * s.vp / (2 * d);
  s.length_s = s.vp / a + std::max(0.0, D - s.sa - s.sd) / s.vp + s.vp / d;
  return s;
}

// When the carriage has covered x of D, from the motion's start.
double time_to(const Shape& s, double D, double a, double d, double x) {
  if (x <= s.sa) return std::sqrt(2 * std::max(0.0, x) / a);
  if (x <= D - s.sd) return s.vp / a + (x - s.sa) / s.vp;
  return s.length_s - std::sqrt(2 * std::max(0.0, D - x) / d);
}

struct Along {
  double t_s, window_s, x_mm;  // x: covered since the start, toward the target
};

// The motion's start times every sample allows at cruise speed v: an empty
// interval (hi < lo) when no start agrees with all of them.
struct StartRange {
  double lo = -std::numeric_limits<double>::infinity();
  double hi = std::numeric_limits<double>::infinity();
};

StartRange starts_allowed(const std::vector<Along>& xs, double D, const Trapezoid& k, double v) {
  const Shape s = shape(D, v, k.accel_mm_s2, k.decel_mm_s2);
  StartRange r;
  for (const Along& p : xs) {
    if (p.x_mm <= kAtRestMm) {
      // Still at the start: the motion had not covered kAtRestMm yet.
      r.lo = std::max(r.lo,
                      p.t_s - p.window_s - time_to(s, D, k.accel_mm_s2, k.decel_mm_s2, kAtRestMm));
    } else if (p.x_mm >= D - kAtRestMm) {
      // On the target: the motion had covered all but kAtRestMm.
      r.hi = std::min(
          r.hi, p.t_s + p.window_s - time_to(s, D, k.accel_mm_s2, k.decel_mm_s2, D - kAtRestMm));
    } else {
      // The carriage was within half a step of x: it got there between these.
      const auto when = [&](double x) {
        return time_to(s, D, k.accel_mm_s2, k.decel_mm_s2, std::clamp(x, 0.0, D));
      };
      r.lo = std::max(r.lo, p.t_s - when(p.x_mm + kPositionHalfStepMm) - p.window_s);
      r.hi = std::min(r.hi, p.t_s - when(p.x_mm - kPositionHalfStepMm) + p.window_s);
    }
  }
  return r;
}

}  // namespace

EdgeBounds busy_edge_bounds(const std::vector<ProfileSample>& samples, const Trapezoid& asked) {
  EdgeBounds b;
  const double D = std::abs(asked.to_mm - asked.from_mm);
  const double a = asked.accel_mm_s2, d = asked.decel_mm_s2, v = asked.speed_mm_s * kFastest;
  if (!(D > 2 * kAtRestMm) || !(v > 0) || !(a > 0) || !(d > 0)) return b;
  const double dir = asked.to_mm >= asked.from_mm ? 1.0 : -1.0;
  // The fastest from rest over x, and the fastest over r to rest.
  const auto from_rest = [&](double x) {
    return x <= v * v / (2 * a) ? std::sqrt(2 * x / a) : v / a + (x - v * v / (2 * a)) / v;
  };
  const auto to_rest = [&](double r) {
    return r >= v * v / (2 * d) ? r / v + v / (2 * d) : std::sqrt(2 * r / d);
  };
  for (const ProfileSample& p : samples) {
    const double x = (p.position_mm - asked.from_mm) * dir;
    if (x <= kAtRestMm || x >= D - kAtRestMm) continue;  // not surely moving
    const double w = p.window_s + kStampSlackS;
    const double rise = p.t_s + w - from_rest(std::max(0.0, x - kPositionHalfStepMm));
    const double fall = p.t_s - w + to_rest(std::max(0.0, D - x - kPositionHalfStepMm));
    b.rise_before = std::min(b.rise_before.value_or(rise), rise);
    b.fall_after = std::max(b.fall_after.value_or(fall), fall);
  }
  return b;
}

double trapezoid_duration_s(double distance_mm, double v_mm_s, double accel, double decel) {
  return shape(distance_mm, v_mm_s, accel, decel).length_s;
}

std::optional<ProfileFit> fit_profile(const std::vector<ProfileSample>& samples,
                                      const Trapezoid& asked) {
  const double D = std::abs(asked.to_mm - asked.from_mm);
  if (!(D > 2 * kAtRestMm) || !(asked.speed_mm_s > 0) || !(asked.accel_mm_s2 > 0) ||
      !(asked.decel_mm_s2 > 0))
    return std::nullopt;
  const double dir = asked.to_mm >= asked.from_mm ? 1.0 : -1.0;
  std::vector<Along> xs;
  int moving = 0;
  for (const ProfileSample& p : samples) {
    const double x = (p.position_mm - asked.from_mm) * dir;
    // Behind the start or past the target: not this trapezoid (an overshoot,
    // another motion); the fit would have to ignore what it cannot explain.
    if (x < -kAtRestMm || x > D + kAtRestMm) return std::nullopt;
    if (x > kAtRestMm && x < D - kAtRestMm) ++moving;
    xs.push_back({p.t_s, p.window_s + kStampSlackS, x});
  }
  if (moving < kMovingSamples) return std::nullopt;

  // Every cruise speed the samples allow, and the one they allow best (the
  // widest common start range).
  double best_v = 0, best_slack = -1, best_start = 0;
  double shortest = std::numeric_limits<double>::infinity(), longest = 0;
  bool slowest_allowed = false;
  for (int i = 0; i <= kSpeeds; ++i) {
    const double f = kSlowest + (kFastest - kSlowest) * double(i) / kSpeeds;
    const double v = asked.speed_mm_s * f;
    const StartRange r = starts_allowed(xs, D, asked, v);
    if (r.hi < r.lo) continue;
    if (i == 0) slowest_allowed = true;
    const double length = trapezoid_duration_s(D, v, asked.accel_mm_s2, asked.decel_mm_s2);
    shortest = std::min(shortest, length);
    longest = std::max(longest, length);
    if (r.hi - r.lo > best_slack) {
      best_slack = r.hi - r.lo;
      best_v = v;
      best_start = std::isfinite(r.lo) && std::isfinite(r.hi) ? (r.lo + r.hi) / 2 : r.lo;
    }
  }
  if (best_slack < 0 || slowest_allowed) return std::nullopt;
  ProfileFit fit;
  fit.speed_mm_s = std::min(best_v, asked.speed_mm_s);
  fit.duration_s = trapezoid_duration_s(D, best_v, asked.accel_mm_s2, asked.decel_mm_s2);
  // The grid's own step counts too: the truth may lie between two speeds
  // tried (a reviewer's case: at slow speeds the step is wider than 1/kSpeeds
  // of the speed found).
  const double grid_step = asked.speed_mm_s * (kFastest - kSlowest) / kSpeeds;
  const double step_s = std::abs(trapezoid_duration_s(D, std::max(best_v - grid_step, 1e-9),
                                                      asked.accel_mm_s2, asked.decel_mm_s2) -
                                 fit.duration_s);
  fit.pm_s = std::max(longest - fit.duration_s, fit.duration_s - shortest) + step_s;
  fit.start_s = best_start;
  fit.moving_samples = moving;
  return fit;
}

}  // namespace lec6::serve::history
