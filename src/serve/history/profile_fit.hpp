#pragma once
// A positioning motion's duration from where the carriage was seen (issue 32
// rule 1), not from when the polls that saw BUSY ran. Sans-I/O, pure.
//
// The controller moves on the digest's trapezoid (§6): from rest, at the
// acceleration it was given up to a cruise speed, then the deceleration to
// rest on the target; BUSY is on from the motion's start to its end (the twin
// holds both; a real controller's BUSY delay only moves the start). The
// acceleration and deceleration are the ones the move wrote. The cruise
// speed V is left free, because wear is what lowers it. Each position sample
// taken during the motion says when the motion began, given V; the V that
// makes the samples agree is the fit, and the duration is the profile's
// length at that V: the poll gap does not enter it.
//
// Its ± is what the samples allow: the controller read each position within
// its read's query-to-reply window (a hard bound), so every V whose samples
// still agree to within those windows is possible, and the ± spans their
// durations. A fit is refused (nullopt) when fewer than two samples were
// taken during the motion, when the samples disagree by more than their
// windows at every V (not this trapezoid: a retarget, a hold, a push, another
// profile), or when the V the samples allow reaches the slowest one
// considered (the samples do not pin it down).
//
// profile_fit_test.cpp attacks it: samples at any phase and gap of a
// simulated motion, wear, a retarget, and too few samples.

#include <optional>
#include <vector>

namespace lec6::serve::history {

struct ProfileSample {
  double t_s = 0;          // the middle of the read's window on the wire, seconds (any origin)
  double window_s = 0;     // half its width: the controller took the sample within t_s ± window_s
  double position_mm = 0;  // D9000
};

struct Trapezoid {
  double from_mm = 0, to_mm = 0;
  double speed_mm_s = 0;   // the speed written: the fastest the cruise can be
  double accel_mm_s2 = 0;  // written acceleration
  double decel_mm_s2 = 0;  // written deceleration
};

struct ProfileFit {
  double duration_s = 0;  // the profile's length at the fitted speed
  double pm_s = 0;        // ± from the samples' windows
  double speed_mm_s = 0;  // the fitted cruise speed
  double start_s = 0;     // when the motion began, on the samples' clock
  int moving_samples = 0;
};

std::optional<ProfileFit> fit_profile(const std::vector<ProfileSample>& samples,
                                      const Trapezoid& asked);

// What the samples say of BUSY's edges whatever the controller's ramps, as
// long as it never accelerates or decelerates harder than written nor runs
// faster than 1 % above the speed written, and BUSY is on while it moves:
// BUSY rose no later than `rise_before` (the carriage could not have come
// that far any faster) and fell no earlier than `fall_after` (nor could it
// have covered what was left and stopped sooner). On the samples' clock.
struct EdgeBounds {
  std::optional<double> rise_before, fall_after;
};
EdgeBounds busy_edge_bounds(const std::vector<ProfileSample>& samples, const Trapezoid& asked);

// The profile's length: from rest to rest over |to − from| at cruise speed v.
double trapezoid_duration_s(double distance_mm, double v_mm_s, double accel, double decel);

}  // namespace lec6::serve::history
