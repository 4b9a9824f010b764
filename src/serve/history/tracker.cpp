#include "tracker.hpp"

#include "profile_fit.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

namespace lec6::serve::history {
namespace {

std::optional<double> number(const nlohmann::json& j, const char* key) {
  const auto it = j.find(key);
  if (it == j.end() || !it->is_number()) return std::nullopt;
  return it->get<double>();
}

bool is_motion_op(const std::string& op) {
  return op == "home" || op == "move" || op == "run-step" || op == "jog";
}

}  // namespace

void time_from_brackets(MotionRecord& r, double up_after_s, double down_after_s) {
  const double up = (up_after_s + *r.busy_up_s) / 2, down = (down_after_s + *r.busy_down_s) / 2;
  r.duration_s = down - up;
  r.duration_pm_s = ((*r.busy_up_s - up_after_s) + (*r.busy_down_s - down_after_s)) / 2;
  r.timed_by = "polls";
}

void settle_from_brackets(MotionRecord& r, double down_after_s, double inp_after_s) {
  const double down = (down_after_s + *r.busy_down_s) / 2, inp = (inp_after_s + *r.inp_s) / 2;
  r.settle_s = std::max(0.0, inp - down);
}

bool refused_before_start(const nlohmann::json& event, const std::string& op) {
  // A move's result carries its timeline once its start was written (the
  // client's MoveResult, ops/op_results.cpp); a 4xx without one is a
  // refusal from the checks before the start (client/actuator.cpp:
  // ready_to_move, soft limits, the step's validation) or from lec serve
  // itself. A jog's result has no timeline: a jog's 4xx is an alarm while
  // it ran, a motion.
  const int status = event.value("status", 0);
  return op != "jog" && status >= 400 && status < 500 && !event.contains("timeline");
}

std::optional<MotionRecord> MotionTracker::op_event(const nlohmann::json& event, TimePoint at,
                                                    int64_t wall_ms) {
  const std::string kind = event.value("event", "");
  const std::string op = event.value("op", "");
  if (kind == "started" && is_motion_op(op)) {
    Motion m;
    m.started = at;
    MotionRecord& r = m.record;
    r.start_ms = wall_ms;
    r.axis = axis_;
    r.source = event.value("source", "");
    r.kind = op;
    if (const auto s = number(event, "step")) r.step = static_cast<int>(*s);
    r.target_mm = number(event, "target_mm");
    r.speed_mm_s = number(event, "speed_mm_s");
    r.accel_mm_s2 = number(event, "acceleration_mm_s2");
    r.force_pct = number(event, "moving_force_pct");
    r.pushing_force_pct = number(event, "pushing_force_pct");
    if (op == "home") r.target_mm = 0;
    if (last_) {
      r.start_mm = last_->position_mm;
      m.samples.push_back(*last_);
    }
    motion_ = std::move(m);  // a motion telemetry was following becomes this one
    return std::nullopt;
  }
  // A stop, hold, reset or servo off of ours during the motion: whatever it
  // did, the motion is not one trapezoid any more (a hold and resume).
  if (kind == "started" && motion_ && !is_motion_op(op)) motion_->interrupted = true;
  if (kind != "finished" || !motion_ || motion_->by_telemetry) return std::nullopt;
  // Operations end one at a time per axis: a finished event without a
  // motion op is a stop/reset/hold reply; the motion's own comes later.
  if (!is_motion_op(op) && op != "") return std::nullopt;
  Motion m = std::move(*motion_);
  motion_.reset();
  MotionRecord& r = m.record;
  if (refused_before_start(event, op)) {
    // Nothing reached the wire that could move the axis (servo off, a soft
    // limit, an alarm already active, a stop that came first): an event of
    // the history, not a motion (no odometer move, no alarm count, no drift).
    r.outcome = "refused";
    return r;
  }
  wait_idle_ = true;
  r.outcome = event.value("outcome", event.value("ok", false) ? "reached" : "not_started");
  if (const auto it = event.find("timeline"); it != event.end() && it->is_object()) {
    r.busy_up_s = number(*it, "busy_up_s");
    r.busy_down_s = number(*it, "busy_down_s");
    r.inp_s = number(*it, "inp_s");
  }
  const auto elapsed = number(event, "elapsed_s");
  std::optional<double> up_after, down_after, inp_after;
  if (const auto it = event.find("timeline"); it != event.end() && it->is_object()) {
    up_after = number(*it, "busy_up_after_s");
    down_after = number(*it, "busy_down_after_s");
    inp_after = number(*it, "inp_after_s");
  }
  if (r.busy_up_s && r.busy_down_s && up_after && down_after) {
    time_from_brackets(r, *up_after, *down_after);
  } else if (!r.busy_up_s && event.contains("timeline")) {
    r.duration_s = kNoDuration;  // BUSY never seen: no duration (not the start window's)
  } else {
    r.duration_s = r.busy_down_s.value_or(elapsed.value_or(to_seconds(at - m.started)));
  }
  if (r.busy_down_s && r.inp_s) {
    r.settle_s = std::max(0.0, *r.inp_s - *r.busy_down_s);
    if (down_after && inp_after) settle_from_brackets(r, *down_after, *inp_after);
  }
  if (!r.target_mm || r.kind == "move" || r.kind == "run-step") {
    if (const auto t = number(event, "target_mm")) r.target_mm = t;
  }
  if (const auto it = event.find("alarms"); it != event.end() && it->is_array()) {
    for (const auto& a : *it) {
      if (a.is_object() && a.contains("code")) r.alarms.push_back(a["code"].get<int>());
    }
  }
  if (up_after && down_after) time_from_positions(m, event, r, *up_after, *down_after);
  const auto final_mm = number(event, "position_mm");
  if (final_mm) {
    m.samples.push_back({at, *final_mm, number(event, "speed_mm_s").value_or(0),
                         number(event, "thrust_pct").value_or(0)});
  }
  return finish(m, final_mm);
}

std::optional<MotionRecord> MotionTracker::telemetry(const std::optional<lec::StateData>& state,
                                                     const std::optional<lec::StatusFlags>& flags,
                                                     TimePoint at, int64_t wall_ms,
                                                     std::optional<TimePoint> sent) {
  const std::optional<Sample> before = last_;
  if (state) {
    last_ = Sample{at, state->position_001mm / 100.0, double(state->speed_mm_s),
                   double(state->thrust_pct), sent && *sent <= at ? *sent : TimePoint{}};
    if (motion_) keep(*motion_, *last_);
  }
  if (!flags) return std::nullopt;
  const bool busy = flags->busy();
  const bool rose = busy && !last_busy_;
  last_busy_ = busy;
  const std::optional<TimePoint> flags_before = last_flags_at_;
  last_flags_at_ = sent && *sent <= at ? *sent : at;
  if (!busy) wait_idle_ = false;
  if (!motion_) {
    if (!rose || wait_idle_) return std::nullopt;
    // Moving, and not by an operation of ours: another master or Modbus TCP.
    Motion m;
    m.by_telemetry = true;
    m.started = at;
    m.record.start_ms = wall_ms;
    m.record.axis = axis_;
    m.record.source = "telemetry";
    m.record.kind = "move";
    if (state) {
      m.record.target_mm = state->target_001mm / 100.0;
      if (state->step_no > 0) m.record.step = state->step_no;
    }
    // The last sample before this read is where it started from.
    if (const auto& from = before ? before : last_) {
      m.record.start_mm = from->position_mm;
      m.samples.push_back(*from);
      if (before && state) m.samples.push_back(*last_);
    }
    m.record.busy_up_s = 0;
    if (flags_before) m.up_after_s = to_seconds(*flags_before - at);
    motion_ = std::move(m);
    return std::nullopt;
  }
  Motion& m = *motion_;
  if (busy) {
    m.high_last_sent = last_flags_at_;
    m.low_after_at.reset();
  } else if (!m.busy_seen) {
    m.low_before_sent = last_flags_at_;
  } else if (!m.low_after_at) {
    m.low_after_at = at;
  }
  if (busy && !m.busy_seen) m.busy_seen = at;
  if (busy && !m.busy_down && state && before) {
    const bool still = state->speed_mm_s == 0 &&
                       std::abs(state->position_001mm / 100.0 - before->position_mm) < 0.02;
    if (!still) {
      m.rest_since.reset();
    } else if (!m.rest_since) {
      m.rest_since = before->at;
    } else if (at - *m.rest_since >= kRestCloses) {
      // Left at rest with BUSY on (a hold, a pause): the motion ended when
      // the carriage stopped; what follows until BUSY falls is not motion,
      // whoever started it (an operation of ours ends later, at its
      // deadline or its release: its finished event then finds no motion).
      MotionRecord& r = m.record;
      r.busy_down_s = to_seconds(*m.rest_since - m.started);
      const double up_s =
          m.by_telemetry ? 0.0 : to_seconds(m.busy_seen.value_or(m.started) - m.started);
      if (!m.by_telemetry) r.busy_up_s = up_s;
      r.duration_s = *r.busy_down_s - up_s;
      r.outcome = "stopped";
      Motion done = std::move(m);
      motion_.reset();
      wait_idle_ = true;
      return finish(done, last_ ? std::optional<double>(last_->position_mm) : std::nullopt);
    }
  }
  if (!m.by_telemetry) return std::nullopt;
  if (state) m.record.target_mm = state->target_001mm / 100.0;
  if (!busy && !m.busy_down) {
    m.busy_down = at;
    m.record.busy_down_s = to_seconds(at - m.started);
    if (flags_before) m.down_after_s = to_seconds(*flags_before - m.started);
  }
  if (!m.busy_down) return std::nullopt;
  const bool settled =
      flags->inp() || flags->alarm() || at - *m.busy_down >= std::chrono::seconds(1);
  if (!settled) return std::nullopt;
  MotionRecord& r = m.record;
  r.duration_s = *r.busy_down_s;
  if (m.up_after_s && m.down_after_s) time_from_brackets(r, *m.up_after_s, *m.down_after_s);
  if (flags->inp()) {
    r.inp_s = to_seconds(at - m.started);
    r.settle_s = *r.inp_s - *r.busy_down_s;
    if (m.down_after_s && flags_before)
      settle_from_brackets(r, *m.down_after_s, to_seconds(*flags_before - m.started));
  }
  r.outcome = flags->alarm() ? "alarm" : flags->inp() ? "reached" : "stopped";
  Motion done = std::move(m);
  motion_.reset();
  return finish(done, last_ ? std::optional<double>(last_->position_mm) : std::nullopt);
}

void MotionTracker::time_from_positions(const Motion& m, const nlohmann::json& event,
                                        MotionRecord& r, double up_after_s, double down_after_s) {
  const auto it = event.find("profile");
  const auto tl = event.find("timeline");
  if (it == event.end() || !it->is_object() || tl == event.end() || !tl->is_object() ||
      r.outcome != "reached" || !r.target_mm || std::isnan(r.duration_s) || !r.duration_pm_s ||
      !r.busy_up_s || !r.busy_down_s || m.interrupted)
    return;
  // Where the carriage stood at rest in the operation's own read just before
  // the start: the telemetry's last sample may be older (a reviewer's case:
  // a stale start read every fitted duration wrong).
  const auto from = number(*it, "from_mm");
  const auto origin = tl->find("origin_ns");
  if (!from || origin == tl->end() || !origin->is_number_integer()) return;
  Trapezoid asked;
  asked.from_mm = *from;
  asked.to_mm = *r.target_mm;
  asked.speed_mm_s = number(*it, "speed_mm_s").value_or(0);
  asked.accel_mm_s2 = number(*it, "acceleration_mm_s2").value_or(0);
  asked.decel_mm_s2 = number(*it, "deceleration_mm_s2").value_or(0);
  std::vector<ProfileSample> xs;
  for (const Sample& s : m.samples) {
    if (s.sent == TimePoint{}) continue;
    xs.push_back({to_seconds(s.sent - m.started) + to_seconds(s.at - s.sent) / 2,
                  to_seconds(s.at - s.sent) / 2, s.position_mm});
  }
  // BUSY's brackets on the samples' clock (the timeline counts from its
  // origin), narrowed by what the positions allow whatever the ramps.
  const double k =
      to_seconds(TimePoint{} + std::chrono::nanoseconds(origin->get<int64_t>()) - m.started);
  double rise_lo = k + up_after_s, rise_hi = k + *r.busy_up_s;
  double fall_lo = k + down_after_s, fall_hi = k + *r.busy_down_s;
  // Every read of the flags (the telemetry's too) brackets the edges; the
  // rise only where a read saw BUSY = 0 after the operation began (else the
  // first BUSY = 1 may be an earlier motion's).
  const auto secs = [&](TimePoint t) { return to_seconds(t - m.started); };
  if (m.busy_seen && m.low_before_sent) {
    rise_lo = std::max(rise_lo, secs(*m.low_before_sent));
    rise_hi = std::min(rise_hi, secs(*m.busy_seen));
  }
  if (m.high_last_sent && m.low_after_at) {
    fall_lo = std::max(fall_lo, secs(*m.high_last_sent));
    fall_hi = std::min(fall_hi, secs(*m.low_after_at));
  }
  const EdgeBounds edges = busy_edge_bounds(xs, asked);
  if (edges.rise_before) rise_hi = std::min(rise_hi, *edges.rise_before);
  if (edges.fall_after) fall_lo = std::max(fall_lo, *edges.fall_after);
  if (rise_hi < rise_lo || fall_hi < fall_lo) return;  // not what the bounds assume
  const double b_lo = fall_lo - rise_hi, b_hi = fall_hi - rise_lo;
  if ((b_hi - b_lo) / 2 < *r.duration_pm_s) {
    r.duration_s = (b_lo + b_hi) / 2;
    r.duration_pm_s = (b_hi - b_lo) / 2;
    r.timed_by = "positions";
  }
  const auto fit = fit_profile(xs, asked);
  if (!fit) return;
  // The brackets bound the true duration; the fit, corrected by the offset
  // the recent moves of these settings allow, bounds it too: both hold.
  const std::string key =
      fmt::format("{}>{} v{} a{} d{}", std::lround(asked.from_mm * 2), std::lround(asked.to_mm * 2),
                  asked.speed_mm_s, asked.accel_mm_s2, asked.decel_mm_s2);
  const FitOffsets::Range c =
      offsets_.add(key, {b_lo - fit->duration_s - fit->pm_s, b_hi - fit->duration_s + fit->pm_s});
  const double lo = std::max(b_lo, fit->duration_s - fit->pm_s + c.lo);
  const double hi = std::min(b_hi, fit->duration_s + fit->pm_s + c.hi);
  if (hi < lo || (hi - lo) / 2 >= *r.duration_pm_s) return;
  r.duration_s = (lo + hi) / 2;
  r.duration_pm_s = (hi - lo) / 2;
  r.timed_by = "positions";
}

void MotionTracker::keep(Motion& m, const Sample& s) {
  m.samples.push_back(s);
  if (m.samples.size() <= kMaxSamples) return;
  // Merge pairs after the first (the start): the later one's time and
  // position, the larger thrust and speed of the two.
  std::vector<Sample> merged{m.samples.front()};
  for (std::size_t i = 1; i + 1 < m.samples.size(); i += 2) {
    Sample a = m.samples[i + 1];
    a.thrust_pct = std::max(a.thrust_pct, m.samples[i].thrust_pct);
    a.speed_mm_s = std::max(a.speed_mm_s, m.samples[i].speed_mm_s);
    merged.push_back(a);
  }
  if (m.samples.size() % 2 == 0) merged.push_back(m.samples.back());
  m.samples = std::move(merged);
}

MotionRecord MotionTracker::finish(Motion& m, std::optional<double> final_mm) {
  MotionRecord& r = m.record;
  if (m.samples.empty()) return r;
  double peak_thrust = 0, sum_thrust = 0, peak_speed = 0, distance = 0;
  std::size_t n = 0;
  for (std::size_t i = 0; i < m.samples.size(); ++i) {
    const Sample& s = m.samples[i];
    if (i > 0) distance += std::abs(s.position_mm - m.samples[i - 1].position_mm);
    // The sample taken before the start is the start position, not the motion.
    if (i == 0 && m.samples.size() > 1) continue;
    peak_thrust = std::max(peak_thrust, s.thrust_pct);
    peak_speed = std::max(peak_speed, s.speed_mm_s);
    sum_thrust += s.thrust_pct;
    ++n;
  }
  r.distance_mm = distance;
  if (n > 0) {
    r.peak_thrust_pct = peak_thrust;
    r.mean_thrust_pct = sum_thrust / double(n);
    r.peak_speed_mm_s = peak_speed;
  }
  if (r.target_mm && r.start_mm && r.kind != "jog") {
    const double dir = *r.target_mm >= *r.start_mm ? 1.0 : -1.0;
    double over = 0;
    for (const Sample& s : m.samples) over = std::max(over, (s.position_mm - *r.target_mm) * dir);
    r.overshoot_mm = over;
  }
  if (r.target_mm && final_mm && r.kind != "jog") r.final_error_mm = *final_mm - *r.target_mm;
  return r;
}

}  // namespace lec6::serve::history
