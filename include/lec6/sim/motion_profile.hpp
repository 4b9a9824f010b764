#pragma once
// Analytic one-axis motion (digest §6): piecewise constant-acceleration
// segments computed once when a move is planned, then evaluated at any time
// point. There is no tick: the position at t is a closed-form function of t,
// so a virtual clock can jump straight to the instant something happens.
//
// Units: mm, mm/s, mm/s²; time on the library's TimePoint.
//
// Thread safety: value types and pure functions; const objects may be shared between threads,
// writes need the caller's synchronisation.

#include <optional>
#include <vector>

#include "lec6/clock.hpp"

namespace lec6::sim {

// Where the carriage is and how it moves at one instant.
struct Kinematics {
  double position = 0.0;      // mm
  double velocity = 0.0;      // mm/s, signed
  double acceleration = 0.0;  // mm/s², signed
};

// The limits of one move. All must be > 0 (a planner clamps nothing).
struct MoveLimits {
  double speed = 1.0;         // mm/s, top speed of the cruise
  double acceleration = 1.0;  // mm/s², speeding up
  double deceleration = 1.0;  // mm/s², slowing down (also used to brake a wrong-way start)
};

class MotionProfile {
 public:
  // At rest at `position` forever.
  static MotionProfile hold(TimePoint t0, double position);

  // From (position, velocity) at t0 to rest at `target`. Handles every start:
  // at rest, moving toward the target below/above `limits.speed`, moving away
  // from it, or too fast to stop before it (it brakes, overshoots and comes
  // back). Trapezoidal when the cruise speed is reached, triangular otherwise.
  static MotionProfile plan(TimePoint t0, double position, double velocity, double target,
                            const MoveLimits& limits);

  // From (position, velocity) at t0 to rest as soon as `deceleration` allows.
  static MotionProfile stop(TimePoint t0, double position, double velocity, double deceleration);

  // The state at `t`; before the start it is the start state (at its
  // velocity), after the end it is the end state at rest.
  Kinematics at(TimePoint t) const;
  double position(TimePoint t) const { return at(t).position; }
  double velocity(TimePoint t) const { return at(t).velocity; }

  TimePoint start_time() const { return t0_; }
  // When the carriage comes to rest for good.
  TimePoint end_time() const;
  double final_position() const { return final_position_; }
  bool moving(TimePoint t) const { return t < end_time() && !segments_.empty(); }

  // The first instant in [from, end_time()] when the position equals `value`
  // (crossing or touching it), or nullopt when it never does. If the position
  // already equals it at `from`, that is `from`.
  std::optional<TimePoint> first_crossing(double value, TimePoint from) const;

  // Truncates the profile at `t`, the carriage held still from there on
  // (a collision: it stops dead against an obstacle).
  MotionProfile halted_at(TimePoint t) const;

  struct Segment {
    double t_start = 0.0;  // s from t0
    double duration = 0.0;
    double p0 = 0.0;
    double v0 = 0.0;
    double a = 0.0;
  };
  const std::vector<Segment>& segments() const { return segments_; }

 private:
  void push(double duration, double a);
  Kinematics eval(double s) const;

  TimePoint t0_{};
  double start_position_ = 0.0;
  double start_velocity_ = 0.0;
  double final_position_ = 0.0;
  double total_ = 0.0;  // s
  std::vector<Segment> segments_;
};

}  // namespace lec6::sim
