// The twin controller's state machine: power-on, time and events (SVRE
// rising, phase ends, contact with the workpiece, stall alarms) and what the
// master reads (flags, state data). Operations started by the inputs are in
// controller_operations.cpp; the Modbus memory map onto those inputs and
// outputs is register_adapter.cpp. Each behaviour a master can observe is a row of
// docs/twin-fidelity.md (its source and how to confirm it on a real controller).

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "lec6/error.hpp"
#include "lec6/sim/controller.hpp"
#include "sim/controller_math.hpp"

namespace lec6::sim {

using detail::clamp_i32;
using detail::clamp_u16;
using detail::kEps;
using detail::sign_of;

std::vector<std::string> validate(const ActuatorConfig& c) {
  std::vector<std::string> e;
  auto positive = [&](double v, const char* name) {
    if (!(v > 0.0) || !std::isfinite(v))
      e.push_back(fmt::format("{} must be > 0 (is {})", name, v));
  };
  if (!(c.stroke_min_mm <= 0.0 && c.stroke_max_mm >= 0.0 && c.stroke_min_mm < c.stroke_max_mm)) {
    e.push_back(fmt::format("stroke [{}, {}] mm must satisfy min ≤ 0 ≤ max and min < max",
                            c.stroke_min_mm, c.stroke_max_mm));
  }
  positive(c.max_speed_mm_s, "max speed");
  positive(c.max_accel_mm_s2, "max acceleration");
  positive(c.jog_speed_mm_s, "jog speed");
  positive(c.jog_accel_mm_s2, "jog acceleration");
  positive(c.origin_speed_mm_s, "origin-return speed");
  positive(c.origin_accel_mm_s2, "origin-return acceleration");
  if (!(c.initial_position_mm >= c.stroke_min_mm && c.initial_position_mm <= c.stroke_max_mm)) {
    e.push_back(fmt::format("initial position {} mm is outside the stroke [{}, {}] mm",
                            c.initial_position_mm, c.stroke_min_mm, c.stroke_max_mm));
  }
  if (c.workpiece_mm && !std::isfinite(*c.workpiece_mm))
    e.push_back("workpiece position must be finite");
  if (c.svre_delay < Duration::zero()) e.push_back("SVRE delay must be ≥ 0");
  if (c.stall_alarm_delay < Duration::zero()) e.push_back("stall alarm delay must be ≥ 0");
  if (c.busy_delay < Duration::zero() || c.busy_delay > std::chrono::seconds(10))
    e.push_back("BUSY delay must be 0 to 10 s");
  if (c.busy_min < Duration::zero() || c.busy_min > std::chrono::seconds(10))
    e.push_back("shortest BUSY pulse must be 0 to 10 s");
  if (c.inp_delay < Duration::zero() || c.inp_delay > std::chrono::seconds(10))
    e.push_back("INP delay must be 0 to 10 s");
  if (!(c.friction_thrust_pct >= 0.0) || !(c.accel_thrust_pct >= 0.0)) {
    e.push_back("thrust model shares must be ≥ 0");
  }
  if (!(c.wear_pct_per_m >= 0.0) || c.wear_pct_per_m > 1000.0) {
    e.push_back("wear must be 0 to 1000 % per metre travelled");
  }
  if (auto n = lec::EquipmentName::make(c.equipment_name); !n) e.push_back(n.error());
  return e;
}

Controller::Controller(const ActuatorConfig& config, TimePoint power_on,
                       const std::optional<Eeprom>& eeprom)
    : config_(config), now_(power_on) {
  if (auto errors = validate(config_); !errors.empty()) {
    std::string all;
    for (const auto& m : errors) all += (all.empty() ? "" : "; ") + m;
    throw InvalidArgument("twin configuration: " + all);
  }
  if (eeprom) {
    eeprom_ = *eeprom;
  } else {
    eeprom_.name = *lec::EquipmentName::make(config_.equipment_name);
  }
  // Incremental encoder: at power-on the position reads 0 wherever the carriage stands.
  offset_mm_ = config_.initial_position_mm;
  profile_ = MotionProfile::hold(now_, config_.initial_position_mm);
  if (config_.workpiece_mm)
    workpiece_side_ = config_.initial_position_mm >= *config_.workpiece_mm ? 1 : -1;
}

void Controller::set_workpiece(std::optional<double> workpiece_mm, TimePoint t) {
  advance(t);
  if (op_.kind != OpKind::None || pending_ || profile_.moving(now_)) {
    throw InvalidArgument("workpiece: the axis is moving; place the workpiece while it is at rest");
  }
  if (workpiece_mm && !std::isfinite(*workpiece_mm)) {
    throw InvalidArgument("workpiece: the position must be a finite number of mm");
  }
  config_.workpiece_mm = workpiece_mm;
  if (workpiece_mm) workpiece_side_ = physical(now_).position >= *workpiece_mm ? 1 : -1;
}

void Controller::restore_eeprom(const Eeprom& e) {
  eeprom_ = e;
  ++eeprom_generation_;
}

// ---- time ---------------------------------------------------------------------

std::optional<TimePoint> Controller::contact_time(TimePoint from) const {
  if (!config_.workpiece_mm || !profile_.moving(from)) return std::nullopt;
  const double wp = *config_.workpiece_mm;
  TimePoint search = from;
  for (int i = 0; i < 8; ++i) {
    auto c = profile_.first_crossing(wp, search);
    if (!c) return std::nullopt;
    const Kinematics k = profile_.at(*c);
    const int dir = std::abs(k.velocity) > kEps ? sign_of(k.velocity) : sign_of(k.acceleration);
    if (dir != 0 && dir == -workpiece_side_) return *c;
    if (*c >= profile_.end_time()) return std::nullopt;
    // Touching it and moving away (a start from the workpiece): look again
    // once the carriage has left the touch tolerance on its own side.
    auto left = profile_.first_crossing(wp + workpiece_side_ * 1e-5, *c);
    if (!left) return std::nullopt;
    search = std::max(*left, *c + Duration(1));
  }
  return std::nullopt;
}

std::optional<Controller::Event> Controller::next_pending() const {
  std::optional<Event> best;
  auto consider = [&](TimePoint at, EventKind kind) {
    if (!best || at < best->at) best = Event{at, kind};
  };
  // Order of consideration breaks ties: SVRE, contact, phase end, stall
  // alarm, BUSY hold end, pending start (a move ending as a retarget begins
  // lets BUSY fall first).
  if (svre_at_) consider(*svre_at_, EventKind::Svre);
  if (auto c = contact_time(now_)) consider(*c, EventKind::Contact);
  switch (op_.kind) {
    case OpKind::Homing:
    case OpKind::Move:
    case OpKind::Jog:
    case OpKind::JogStop:
      if (!op_.held) consider(std::max(profile_.end_time(), now_), EventKind::PhaseEnd);
      break;
    case OpKind::Stalled:
      consider(std::max(op_.stall_alarm_at, now_), EventKind::StallAlarm);
      break;
    case OpKind::None:
      break;
  }
  if (busy_hold_) consider(std::max(busy_hold_->until, now_), EventKind::BusyMinEnd);
  if (pending_) consider(std::max(pending_->at, now_), EventKind::StartDue);
  if (inp_due_) consider(std::max(*inp_due_, now_), EventKind::InpDue);
  return best;
}

std::optional<TimePoint> Controller::next_event() const {
  auto e = next_pending();
  if (!e) return std::nullopt;
  return e->at;
}

void Controller::advance(TimePoint t) {
  for (int guard = 0; guard < 10000; ++guard) {
    auto e = next_pending();
    if (!e || e->at > t) break;
    now_ = std::max(now_, e->at);
    fire(*e);
  }
  now_ = std::max(now_, t);
}

void Controller::fire(const Event& e) {
  switch (e.kind) {
    case EventKind::Svre:
      svre_ = true;
      svre_at_.reset();
      return;
    case EventKind::StallAlarm:
      raise_alarm(op_.stall_alarm);
      return;
    case EventKind::StartDue: {
      const PendingStart start = *pending_;
      pending_.reset();
      begin(start);
      return;
    }
    case EventKind::BusyMinEnd: {
      const bool inp = busy_hold_->inp;
      drop_busy();
      settle_inp(inp);
      return;
    }
    case EventKind::InpDue:
      inp_ = true;
      inp_due_.reset();
      return;
    case EventKind::Contact:
      // The carriage stops dead against the workpiece.
      profile_ = MotionProfile::hold(now_, *config_.workpiece_mm);
      break;
    case EventKind::PhaseEnd:
      break;
  }
  // A jog ends where the carriage stopped, against a workpiece as at the end
  // of its profile (its ramp down, a stroke end): BUSY falls, INP is not judged.
  if (op_.kind == OpKind::Jog || op_.kind == OpKind::JogStop) {
    busy_ = false;
    op_ = Op{};
    return;
  }
  if (e.kind == EventKind::Contact) {
    if (op_.kind == OpKind::Homing) {
      op_.kind = OpKind::Stalled;
      op_.stall_alarm = lec::alarm::kOriginTimeout;
      op_.stall_alarm_at = now_ + config_.stall_alarm_delay;
      op_.stall_thrust = behaviour::kHomingThrustPct;
    } else if (op_.kind == OpKind::Move) {
      if (op_.phase == MovePhase::Push) {
        pressing_ = true;
        pressing_force_ = op_.move.pushing_force;
        // Thrust = pushing force ≥ trigger level (validated at start): INP at once.
        complete(pressing_force_ >= op_.move.trigger_level);
      } else {
        op_.kind = OpKind::Stalled;
        op_.stall_alarm = lec::alarm::kPositioningTimeout;
        op_.stall_alarm_at = now_ + config_.stall_alarm_delay;
        op_.stall_thrust = op_.move.moving_force;
      }
    }
    return;
  }
  // PhaseEnd: the current profile has ended at its target.
  switch (op_.kind) {
    case OpKind::Homing:
      if (op_.homing_phase == 0 && std::abs(homing_end()) > kEps) {
        op_.homing_phase = 1;
        plan_phase();
        return;
      }
      // At the origin: position := 0 (digest §6).
      profile_ = MotionProfile::hold(now_, 0.0);
      offset_mm_ = 0.0;
      seton_ = true;
      target_001mm_ = 0;
      area_mm_.reset();
      complete(true);
      return;
    case OpKind::Move:
      if (op_.stop_first) {  // at rest after a StopThenStart retarget: now the new move
        op_.stop_first = false;
        plan_phase();
        return;
      }
      if (op_.phase == MovePhase::Approach && op_.move.pushing) {
        op_.phase = MovePhase::Push;
        plan_phase();
        return;
      }
      // Positioning: the profile ends on the target, within any in-position width.
      // Pushing phase ended without meeting the workpiece: pushing missed, INP 0.
      complete(op_.phase == MovePhase::Approach);
      return;
    case OpKind::Jog:  // ended above
    case OpKind::JogStop:
    case OpKind::Stalled:
    case OpKind::None:
      return;
  }
}

// ---- reading -----------------------------------------------------------------------

int32_t Controller::to_001mm(double mm) const {
  return clamp_i32(static_cast<int64_t>(std::llround(mm * 100.0)));
}

Kinematics Controller::physical(TimePoint t) {
  advance(t);
  return kin();
}

double Controller::position_mm(TimePoint t) {
  advance(t);
  return reported(kin().position);
}

double Controller::thrust_pct(TimePoint t) {
  advance(t);
  if (pressing_) return pressing_force_;
  if (op_.kind == OpKind::Stalled) return op_.stall_thrust;
  const Kinematics k = kin();
  if (std::abs(k.velocity) < kEps && std::abs(k.acceleration) < kEps) return 0.0;
  const double raw = wear_factor() * (config_.friction_thrust_pct + config_.accel_thrust_pct *
                                                                        std::abs(k.acceleration) /
                                                                        config_.max_accel_mm_s2);
  double cap = behaviour::kJogThrustPct;
  if (op_.kind == OpKind::Move) {
    cap = op_.phase == MovePhase::Push ? op_.move.pushing_force : op_.move.moving_force;
  } else if (op_.kind == OpKind::Homing) {
    cap = behaviour::kHomingThrustPct;
  }
  return std::min(raw, cap);
}

lec::StatusFlags Controller::status(TimePoint t) {
  advance(t);
  const double pos = reported(kin().position);
  lec::StatusFlags f;
  f.set_out(out_);
  f.set(lec::StatusFlags::Busy, busy_);
  f.set(lec::StatusFlags::Svre, svre_);
  f.set(lec::StatusFlags::Seton, seton_);
  f.set(lec::StatusFlags::Inp, inp_);
  f.set(lec::StatusFlags::Area, area_mm_ && area_mm_->contains(pos));
  f.set(lec::StatusFlags::Warea, config_.warea_mm && config_.warea_mm->contains(pos));
  f.set(lec::StatusFlags::Estop, estop_);
  // R-FLAG-ALARM-POLARITY: X4F as the manual says (1 = alarm), or inverted.
  f.set(lec::StatusFlags::Alarm,
        alarm_.has_value() != (config_.alarm_polarity == ActuatorConfig::AlarmPolarity::ActiveLow));
  return f;
}

lec::StateData Controller::state(TimePoint t) {
  advance(t);
  const Kinematics k = kin();
  lec::StateData s;
  s.position_001mm = to_001mm(reported(k.position));
  s.speed_mm_s = clamp_u16(std::abs(k.velocity));
  s.thrust_pct = clamp_u16(thrust_pct(t));
  s.target_001mm = clamp_i32(target_001mm_);
  s.step_no = step_no_;
  return s;
}

}  // namespace lec6::sim
