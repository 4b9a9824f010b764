// The twin controller's operations (digest §5–§6): what the inputs start and
// stop (servo, homing, step and direct moves, pushing, jog, hold, reset,
// alarms), acting on the edges of Y10–Y1F and Y30. Rows of docs/twin-fidelity.md
// name these functions: change one, update the other.

#include <algorithm>
#include <cmath>

#include "lec6/sim/controller.hpp"
#include "sim/controller_math.hpp"

namespace lec6::sim {

using detail::clamp_i32;
using detail::kEps;
using lec::Coil;

double Controller::current_decel() const {
  switch (op_.kind) {
    case OpKind::Homing:
      return config_.origin_accel_mm_s2;
    case OpKind::Move:
      return op_.phase == MovePhase::Push ? op_.move.push.deceleration
                                          : op_.move.approach.deceleration;
    case OpKind::Jog:
    case OpKind::JogStop:
      return config_.jog_accel_mm_s2;
    case OpKind::Stalled:
    case OpKind::None:
      break;
  }
  return config_.max_accel_mm_s2;
}

void Controller::plan_phase() {
  const Kinematics k = kin();
  if (op_.held) {
    profile_ = MotionProfile::stop(now_, k.position, k.velocity, current_decel());
    return;
  }
  if (op_.stop_first) {  // retarget: StopThenStart (R-MOTION-RETARGET)
    profile_ = MotionProfile::stop(now_, k.position, k.velocity, current_decel());
    return;
  }
  double target = k.position;
  MoveLimits limits;
  switch (op_.kind) {
    case OpKind::Homing:
      target = op_.homing_phase == 0 ? homing_end() : 0.0;
      limits = {config_.origin_speed_mm_s, config_.origin_accel_mm_s2, config_.origin_accel_mm_s2};
      break;
    case OpKind::Move:
      if (op_.phase == MovePhase::Approach) {
        target = op_.move.target_phys;
        limits = op_.move.approach;
      } else {
        target = op_.move.push_end_phys;
        limits = op_.move.push;
      }
      break;
    case OpKind::Jog:
      target = op_.jog_dir > 0 ? config_.stroke_max_mm : config_.stroke_min_mm;
      limits = {config_.jog_speed_mm_s, config_.jog_accel_mm_s2, config_.jog_accel_mm_s2};
      break;
    case OpKind::JogStop:
    case OpKind::Stalled:
    case OpKind::None:
      return;
  }
  limits.speed /= wear_factor();  // a worn axis runs slower (wear_pct_per_m)
  profile_ = MotionProfile::plan(now_, k.position, k.velocity, target, limits);
}

void Controller::cancel_op(double deceleration) {
  const Kinematics k = kin();
  profile_ = MotionProfile::stop(now_, k.position, k.velocity, deceleration);
  op_ = Op{};
  drop_busy();
  clear_inp();
  pressing_ = false;
}

void Controller::servo_off() {
  svre_ = false;
  svre_at_.reset();
  cancel_pending();
  // Servo released: the carriage stops where it is (no coasting modelled).
  profile_ = MotionProfile::hold(now_, kin().position);
  op_ = Op{};
  drop_busy();
  clear_inp();
  pressing_ = false;
}

void Controller::raise_alarm(uint8_t code) {
  const double dec = current_decel();
  alarm_ = code;
  lec::AlarmGroup g;
  g.codes[0] = code;
  eeprom_.alarms.push(g);
  ++eeprom_generation_;
  cancel_pending();
  if (op_.kind != OpKind::None) {
    cancel_op(dec);
  } else {
    drop_busy();
    clear_inp();
    pressing_ = false;
  }
}

void Controller::reset() {
  if (alarm_) {
    if (lec::alarm_resettable(*alarm_) || !svre_) alarm_.reset();
    return;
  }
  // R-FLAG-RESET-HOMING: a controller whose RESET does not cancel homing.
  if (op_.kind == OpKind::Homing && !config_.reset_cancels_homing) return;
  cancel_pending();
  if (op_.kind != OpKind::None) {
    cancel_op(current_decel());
  } else if (busy_hold_) {
    drop_busy();
    clear_inp();
  } else if (pressing_) {
    pressing_ = false;
    clear_inp();
  }
}

void Controller::hold_on() {
  switch (op_.kind) {
    case OpKind::Homing:
    case OpKind::Move:
    case OpKind::Jog:
      if (!op_.held) {
        op_.held = true;
        clear_inp();
        plan_phase();
      }
      return;
    default:
      return;
  }
}

void Controller::hold_off() {
  if (!op_.held) return;
  op_.held = false;
  plan_phase();
}

void Controller::start_homing() {
  if (!svre_ || alarm_) return;  // only with SVRE = 1; refused while an alarm is present
  op_ = Op{};
  op_.kind = OpKind::Homing;
  op_.held = control_.test(Coil::HOLD);
  // R-FLAG-SETON-REHOME: SETON falls while a re-home runs, or is kept.
  if (config_.seton_on_rehome == ActuatorConfig::SetonOnRehome::Clear) seton_ = false;
  begin_busy();
  clear_inp();
  pressing_ = false;
  plan_phase();
}

// Why a start of `data` towards `target` is refused now (digest §6, first
// failing check wins): the alarm to raise, or 0 when an alarm is already
// present (ignored). nullopt: accepted.
std::optional<uint8_t> Controller::refusal(const lec::StepData& data, bool is_step,
                                           int64_t target) const {
  if (alarm_) return 0;  // motion refused until RESET
  if (!svre_) return lec::alarm::kServoOff;
  if (is_step && data.is_blank()) return lec::alarm::kStepNotRegistered;
  if (!lec::validate(data).empty()) return lec::alarm::kInvalidData;
  const bool absolute = data.movement_mode == lec::MovementMode::Absolute;
  if (absolute && !seton_) return lec::alarm::kNotHomed;
  const double target_phys = static_cast<double>(target) / 100.0 + offset_mm_;
  if (target != clamp_i32(target) || target_phys < config_.stroke_min_mm - kEps ||
      target_phys > config_.stroke_max_mm + kEps) {
    return is_step ? lec::alarm::kStepBeyondStroke : lec::alarm::kDirectBeyondStroke;
  }
  return std::nullopt;
}

void Controller::start_record(const lec::StepData& data, bool is_step, uint8_t step_no,
                              int64_t base_target) {
  const bool absolute = data.movement_mode == lec::MovementMode::Absolute;
  const int64_t target = absolute ? data.position_001mm : base_target + data.position_001mm;
  if (const auto code = refusal(data, is_step, target)) {
    if (!records_.empty() && !records_.back().busy_rose) records_.back().refused_alarm = *code;
    if (*code != 0) raise_alarm(*code);
    return;
  }
  const double target_phys = static_cast<double>(target) / 100.0 + offset_mm_;

  MoveSpec m;
  const double max_v = config_.max_speed_mm_s;
  const double max_a = config_.max_accel_mm_s2;
  m.approach = {std::min<double>(data.speed_mm_s, max_v),
                std::min<double>(data.acceleration_mm_s2, max_a),
                std::min<double>(data.deceleration_mm_s2, max_a)};
  m.target_phys = target_phys;
  m.moving_force = data.moving_force_pct;
  m.pushing = data.is_pushing();
  if (m.pushing) {
    const double here = kin().position;
    const double dir = target_phys < here - kEps ? -1.0 : 1.0;
    const double distance = static_cast<double>(data.in_position_001mm) / 100.0;
    m.push_end_phys =
        std::clamp(target_phys + dir * distance, config_.stroke_min_mm, config_.stroke_max_mm);
    m.push = {std::min<double>(data.pushing_speed_mm_s, max_v), m.approach.acceleration,
              m.approach.deceleration};
    m.pushing_force = data.pushing_force_pct;
    m.trigger_level = data.trigger_level_pct;
  }

  // R-MOTION-RETARGET: a start while the carriage moves re-plans from the
  // current state, or (StopThenStart) first decelerates to rest.
  const bool moving = profile_.moving(now_);
  op_ = Op{};
  op_.kind = OpKind::Move;
  op_.phase = MovePhase::Approach;
  op_.move = m;
  op_.stop_first = moving && config_.retarget == ActuatorConfig::Retarget::StopThenStart;
  op_.held = control_.test(Coil::HOLD);
  begin_busy();
  clear_inp();
  pressing_ = false;
  out_ = step_no;
  step_no_ = step_no;
  target_001mm_ = target;
  area_mm_ = RangeMm{static_cast<double>(data.area1_001mm) / 100.0,
                     static_cast<double>(data.area2_001mm) / 100.0};
  plan_phase();
}

void Controller::update_jog() {
  const bool minus = control_.test(Coil::JOG_MINUS);
  const bool plus = control_.test(Coil::JOG_PLUS);
  const int dir = plus && !minus ? 1 : (minus && !plus ? -1 : 0);
  if (op_.kind == OpKind::Jog) {
    if (dir == op_.jog_dir) return;
    if (dir == 0) {
      const Kinematics k = kin();
      profile_ = MotionProfile::stop(now_, k.position, k.velocity, config_.jog_accel_mm_s2);
      op_ = Op{};
      op_.kind = OpKind::JogStop;  // BUSY falls when the carriage is at rest
      return;
    }
  }
  if (dir == 0) return;
  const bool free =
      op_.kind == OpKind::None || op_.kind == OpKind::Jog || op_.kind == OpKind::JogStop;
  if (!free || !svre_ || alarm_) return;
  op_ = Op{};
  op_.kind = OpKind::Jog;
  op_.jog_dir = dir;
  op_.held = control_.test(Coil::HOLD);
  busy_hold_.reset();
  busy_ = true;
  clear_inp();
  pressing_ = false;
  plan_phase();
}

void Controller::write_control(const ControlWrite& write) {
  const lec::ControlFlags old = control_;
  control_ = write.flags;
  // Back to parallel mode: the twin's parallel inputs are all open (behaviour.hpp).
  if (old.serial_mode && !control_.serial_mode) control_.y10_1f = 0;
  auto was = [&](Coil c) { return old.test(c); };
  auto is = [&](Coil c) { return control_.test(c); };
  auto rose = [&](Coil c) { return !was(c) && is(c); };
  auto fell = [&](Coil c) { return was(c) && !is(c); };

  if (fell(Coil::SVON)) {
    servo_off();
  } else if (is(Coil::SVON) && (rose(Coil::SVON) || write.svon_written)) {
    if (!svre_ && !svre_at_ && !estop_) svre_at_ = now_ + config_.svre_delay;
  }
  if (rose(Coil::RESET)) reset();
  if (rose(Coil::HOLD)) hold_on();
  if (fell(Coil::HOLD)) hold_off();
  if (rose(Coil::SETUP)) take_start(PendingStart{true, {}, false, 0, target_001mm_, {}});
  if (rose(Coil::DRIVE) && !setup_blocks_starts()) {
    const uint8_t n = control_.selected_step();
    take_start(PendingStart{false, eeprom_.steps[n], true, n, target_001mm_, {}});
  }
  if (was(Coil::JOG_MINUS) != is(Coil::JOG_MINUS) || was(Coil::JOG_PLUS) != is(Coil::JOG_PLUS)) {
    update_jog();
  }
}

void Controller::set_estop(bool on, TimePoint t) {
  advance(t);
  if (on && !estop_) {
    estop_ = true;
    servo_off();
  } else if (!on) {
    estop_ = false;
  }
}

void Controller::inject_alarm(uint8_t code, TimePoint t) {
  advance(t);
  raise_alarm(code);
}

// ---- memory inputs -------------------------------------------------------------

void Controller::write_direct_data(std::size_t index, uint16_t value) {
  if (index < direct_.size()) direct_[index] = value;
}

// R-FLAG-SETUP-HIGH: SETUP left at 1 after a return to origin.
bool Controller::setup_blocks_starts() const {
  return config_.setup_left_high == ActuatorConfig::SetupLeftHigh::RefusesStarts &&
         control_.test(Coil::SETUP);
}

void Controller::start_direct() {
  if (setup_blocks_starts()) return;
  take_start(PendingStart{false,
                          lec::StepData::from_registers(std::span<const uint16_t>(direct_)),
                          false,
                          0,
                          target_001mm_,
                          {}});
}

void Controller::write_steps(const std::map<unsigned, lec::StepData>& steps) {
  bool changed = false;
  for (const auto& [n, data] : steps) {
    if (n >= Eeprom::kSteps) continue;
    eeprom_.steps[n] = data;
    ++eeprom_.step_writes[n];
    changed = true;
  }
  if (changed) ++eeprom_generation_;
}

}  // namespace lec6::sim
