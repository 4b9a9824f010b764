#include "lec6/sim/controller.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <set>
#include <stdexcept>

#include "lec6/lec/memory_map.hpp"

namespace lec6::sim {

namespace {

using lec::Coil;
using modbus::FunctionCode;

constexpr double kEps = 1e-9;

uint16_t clamp_u16(double v) {
  if (!(v > 0.0)) return 0;
  if (v >= 65535.0) return 65535;
  return static_cast<uint16_t>(std::llround(v));
}

int32_t clamp_i32(int64_t v) {
  return static_cast<int32_t>(std::clamp<int64_t>(v, std::numeric_limits<int32_t>::min(),
                                                  std::numeric_limits<int32_t>::max()));
}

int sign_of(double v) {
  return v > 0.0 ? 1 : (v < 0.0 ? -1 : 0);
}

}  // namespace

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
  if (!(c.friction_thrust_pct >= 0.0) || !(c.accel_thrust_pct >= 0.0)) {
    e.push_back("thrust model shares must be ≥ 0");
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
    throw std::invalid_argument("twin configuration: " + all);
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
  // Order of consideration breaks ties: SVRE, contact, phase end, stall alarm.
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
    case EventKind::Contact: {
      // The carriage stops dead against the workpiece.
      profile_ = MotionProfile::hold(now_, *config_.workpiece_mm);
      switch (op_.kind) {
        case OpKind::Homing:
          op_.kind = OpKind::Stalled;
          op_.stall_alarm = lec::alarm::kOriginTimeout;
          op_.stall_alarm_at = now_ + config_.stall_alarm_delay;
          op_.stall_thrust = behaviour::kHomingThrustPct;
          return;
        case OpKind::Move:
          if (op_.phase == MovePhase::Push) {
            pressing_ = true;
            pressing_force_ = op_.move.pushing_force;
            // Thrust = pushing force ≥ trigger level (validated at start): INP at once.
            inp_ = pressing_force_ >= op_.move.trigger_level;
            busy_ = false;
            op_ = Op{};
          } else {
            op_.kind = OpKind::Stalled;
            op_.stall_alarm = lec::alarm::kPositioningTimeout;
            op_.stall_alarm_at = now_ + config_.stall_alarm_delay;
            op_.stall_thrust = op_.move.moving_force;
          }
          return;
        case OpKind::Jog:
        case OpKind::JogStop:
          busy_ = false;
          op_ = Op{};
          return;
        case OpKind::Stalled:
        case OpKind::None:
          return;
      }
      return;
    }
    case EventKind::PhaseEnd:
      break;
  }
  // PhaseEnd: the current profile has ended at its target.
  switch (op_.kind) {
    case OpKind::Homing:
      if (op_.homing_phase == 0 && config_.stroke_min_mm < -kEps) {
        op_.homing_phase = 1;
        plan_phase();
        return;
      }
      // At the origin: position := 0 (digest §6).
      profile_ = MotionProfile::hold(now_, 0.0);
      offset_mm_ = 0.0;
      seton_ = true;
      inp_ = true;
      busy_ = false;
      target_001mm_ = 0;
      area_mm_.reset();
      op_ = Op{};
      return;
    case OpKind::Move:
      if (op_.phase == MovePhase::Approach && op_.move.pushing) {
        op_.phase = MovePhase::Push;
        plan_phase();
        return;
      }
      // Positioning: the profile ends on the target, within any in-position width.
      // Pushing phase ended without meeting the workpiece: pushing missed, INP 0.
      inp_ = op_.phase == MovePhase::Approach;
      busy_ = false;
      op_ = Op{};
      return;
    case OpKind::Jog:
    case OpKind::JogStop:
      busy_ = false;
      op_ = Op{};
      return;
    case OpKind::Stalled:
    case OpKind::None:
      return;
  }
}

// ---- operations ------------------------------------------------------------------

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
  double target = k.position;
  MoveLimits limits;
  switch (op_.kind) {
    case OpKind::Homing:
      target = op_.homing_phase == 0 ? config_.stroke_min_mm : 0.0;
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
  profile_ = MotionProfile::plan(now_, k.position, k.velocity, target, limits);
}

void Controller::cancel_op(double deceleration) {
  const Kinematics k = kin();
  profile_ = MotionProfile::stop(now_, k.position, k.velocity, deceleration);
  op_ = Op{};
  busy_ = false;
  inp_ = false;
  pressing_ = false;
}

void Controller::servo_off() {
  svre_ = false;
  svre_at_.reset();
  // Servo released: the carriage stops where it is (no coasting modelled).
  profile_ = MotionProfile::hold(now_, kin().position);
  op_ = Op{};
  busy_ = false;
  inp_ = false;
  pressing_ = false;
}

void Controller::raise_alarm(uint8_t code) {
  const double dec = current_decel();
  alarm_ = code;
  lec::AlarmGroup g;
  g.codes[0] = code;
  eeprom_.alarms.push(g);
  ++eeprom_generation_;
  if (op_.kind != OpKind::None) {
    cancel_op(dec);
  } else {
    busy_ = false;
    inp_ = false;
    pressing_ = false;
  }
}

void Controller::reset() {
  if (alarm_) {
    if (lec::alarm_resettable(*alarm_) || !svre_) alarm_.reset();
    return;
  }
  if (op_.kind != OpKind::None) {
    cancel_op(current_decel());
  } else if (pressing_) {
    pressing_ = false;
    inp_ = false;
  }
}

void Controller::hold_on() {
  switch (op_.kind) {
    case OpKind::Homing:
    case OpKind::Move:
    case OpKind::Jog:
      if (!op_.held) {
        op_.held = true;
        inp_ = false;
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
  busy_ = true;
  inp_ = false;
  pressing_ = false;
  plan_phase();
}

void Controller::start_record(const lec::StepData& data, bool is_step, uint8_t step_no) {
  if (alarm_) return;  // motion refused until RESET
  if (!svre_) return raise_alarm(lec::alarm::kServoOff);
  if (is_step && data.is_blank()) return raise_alarm(lec::alarm::kStepNotRegistered);
  if (!lec::validate(data).empty()) return raise_alarm(lec::alarm::kInvalidData);
  const bool absolute = data.movement_mode == lec::MovementMode::Absolute;
  if (absolute && !seton_) return raise_alarm(lec::alarm::kNotHomed);
  const int64_t target = absolute ? data.position_001mm : target_001mm_ + data.position_001mm;
  const double target_phys = static_cast<double>(target) / 100.0 + offset_mm_;
  const uint8_t beyond = is_step ? lec::alarm::kStepBeyondStroke : lec::alarm::kDirectBeyondStroke;
  if (target != clamp_i32(target) || target_phys < config_.stroke_min_mm - kEps ||
      target_phys > config_.stroke_max_mm + kEps) {
    return raise_alarm(beyond);
  }

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

  op_ = Op{};
  op_.kind = OpKind::Move;
  op_.phase = MovePhase::Approach;
  op_.move = m;
  op_.held = control_.test(Coil::HOLD);
  busy_ = true;
  inp_ = false;
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
  busy_ = true;
  inp_ = false;
  pressing_ = false;
  plan_phase();
}

void Controller::apply_coils(uint16_t new_y10_1f, bool new_serial, bool wrote_svon) {
  const lec::ControlFlags old = control_;
  control_.serial_mode = new_serial;
  // Back to parallel mode: the twin's parallel inputs are all open (behaviour.hpp).
  if (old.serial_mode && !new_serial) new_y10_1f = 0;
  control_.y10_1f = new_y10_1f;
  auto was = [&](Coil c) { return old.test(c); };
  auto is = [&](Coil c) { return control_.test(c); };
  auto rose = [&](Coil c) { return !was(c) && is(c); };
  auto fell = [&](Coil c) { return was(c) && !is(c); };

  if (fell(Coil::SVON)) {
    servo_off();
  } else if (is(Coil::SVON) && (rose(Coil::SVON) || wrote_svon)) {
    if (!svre_ && !svre_at_ && !estop_) svre_at_ = now_ + config_.svre_delay;
  }
  if (rose(Coil::RESET)) reset();
  if (rose(Coil::HOLD)) hold_on();
  if (fell(Coil::HOLD)) hold_off();
  if (rose(Coil::SETUP)) start_homing();
  if (rose(Coil::DRIVE)) {
    const uint8_t n = control_.selected_step();
    start_record(eeprom_.steps[n], true, n);
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
  const double raw = config_.friction_thrust_pct +
                     config_.accel_thrust_pct * std::abs(k.acceleration) / config_.max_accel_mm_s2;
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
  f.set(lec::StatusFlags::Alarm, alarm_.has_value());
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

// ---- requests ----------------------------------------------------------------------

modbus::Response Controller::handle(const modbus::Request& request, TimePoint t) {
  advance(t);
  const FunctionCode fc = modbus::function_of(request);
  if (auto refusal = lec::check_request(request, control_.serial_mode)) {
    return modbus::ExceptionResponse{fc, static_cast<uint8_t>(fc), refusal->code};
  }
  modbus::Response reply = std::visit(
      [&](const auto& q) -> modbus::Response {
        using T = std::decay_t<decltype(q)>;
        if constexpr (std::is_same_v<T, modbus::ReadBitsRequest>) {
          return read_bits(q);
        } else if constexpr (std::is_same_v<T, modbus::ReadRegistersRequest>) {
          return read_registers(q);
        } else if constexpr (std::is_same_v<T, modbus::WriteCoilRequest>) {
          if (q.coil == lec::address(Coil::SerialMode)) {
            apply_coils(control_.y10_1f, q.on(), false);
          } else {
            const unsigned bit = q.coil - 0x10u;
            uint16_t y = control_.y10_1f;
            y = q.on() ? static_cast<uint16_t>(y | (1u << bit))
                       : static_cast<uint16_t>(y & ~(1u << bit));
            apply_coils(y, control_.serial_mode, q.coil == lec::address(Coil::SVON) && q.on());
          }
          return modbus::WriteCoilResponse{q.coil, q.value};
        } else if constexpr (std::is_same_v<T, modbus::EchoRequest>) {
          return modbus::EchoResponse{q.test_code, q.data};
        } else if constexpr (std::is_same_v<T, modbus::WriteCoilsRequest>) {
          uint16_t y = control_.y10_1f;
          bool serial = control_.serial_mode;
          bool wrote_svon = false;
          for (uint16_t i = 0; i < q.count; ++i) {
            const uint16_t a = static_cast<uint16_t>(q.start + i);
            const bool on = q.bit(i);
            if (a >= 0x10 && a <= 0x1F) {
              const unsigned bit = a - 0x10u;
              y = on ? static_cast<uint16_t>(y | (1u << bit))
                     : static_cast<uint16_t>(y & ~(1u << bit));
              if (a == lec::address(Coil::SVON) && on) wrote_svon = true;
            } else if (a == lec::address(Coil::SerialMode)) {
              serial = on;
            }
          }
          apply_coils(y, serial, wrote_svon);
          return modbus::WriteMultipleResponse{FunctionCode::WriteCoils, q.start, q.count};
        } else {
          write_registers(q);
          return modbus::WriteMultipleResponse{FunctionCode::WriteRegisters, q.start, q.count};
        }
      },
      request);
  // Events due at this very instant (a zero SVRE delay, a zero-length move).
  advance(now_);
  return reply;
}

modbus::Response Controller::read_bits(const modbus::ReadBitsRequest& q) {
  modbus::ReadBitsResponse r;
  r.function = q.function;
  r.packed.assign((q.count + 7u) / 8u, 0);
  const uint16_t x = status(now_).bits;
  for (uint16_t i = 0; i < q.count; ++i) {
    const uint32_t a = static_cast<uint32_t>(q.start) + i;
    bool on = false;
    if (q.function == FunctionCode::ReadCoils) {
      if (a >= 0x10 && a <= 0x1F) on = (control_.y10_1f >> (a - 0x10)) & 1u;
      if (a == lec::address(Coil::SerialMode)) on = control_.serial_mode;
    } else if (a >= lec::kStatusInputs && a < lec::kStatusInputs + lec::kStatusInputCount) {
      on = (x >> (a - lec::kStatusInputs)) & 1u;
    }
    if (on) r.packed[i / 8] = static_cast<uint8_t>(r.packed[i / 8] | (1u << (i % 8)));
  }
  return r;
}

uint16_t Controller::read_register(uint16_t a) {
  if (a >= lec::kEquipmentName && a < lec::kEquipmentName + lec::kEquipmentNameRegisters) {
    return eeprom_.name.to_registers()[a - lec::kEquipmentName];
  }
  if (a >= lec::kAlarmHistory && a < lec::kAlarmHistory + lec::kAlarmHistoryRegisters) {
    return eeprom_.alarms.to_registers()[a - lec::kAlarmHistory];
  }
  if (a >= lec::kStepData && a < lec::kStepData + lec::kStepCount * lec::kStepStride) {
    const unsigned off = a - lec::kStepData;
    return eeprom_.steps[off / lec::kStepStride].to_registers()[off % lec::kStepStride];
  }
  if (a >= lec::kStateData && a < lec::kStateData + lec::kStateDataRegisters) {
    return state(now_).to_registers()[a - lec::kStateData];
  }
  if (a == lec::kStatusWord) return status(now_).bits;
  if (a == lec::kControlWordY10) return control_.y10_1f;
  if (a == lec::kControlWordY30) return control_.serial_mode ? 1 : 0;
  if (a >= lec::kDirectData && a < lec::kDirectData + direct_.size())
    return direct_[a - lec::kDirectData];
  return 0;  // undefined inside an area, and D9100 once the start is processed
}

modbus::Response Controller::read_registers(const modbus::ReadRegistersRequest& q) {
  modbus::ReadRegistersResponse r;
  r.values.reserve(q.count);
  for (uint16_t i = 0; i < q.count; ++i)
    r.values.push_back(read_register(static_cast<uint16_t>(q.start + i)));
  return r;
}

void Controller::write_registers(const modbus::WriteRegistersRequest& q) {
  const std::vector<uint16_t> values = q.values();
  std::set<unsigned> touched;
  std::optional<uint16_t> y10;
  std::optional<uint16_t> y30;
  bool start_direct = false;
  for (uint16_t i = 0; i < q.count && i < values.size(); ++i) {
    const uint16_t a = static_cast<uint16_t>(q.start + i);
    const uint16_t v = values[i];
    if (a >= lec::kStepData && a < lec::kStepData + lec::kStepCount * lec::kStepStride) {
      const unsigned off = a - lec::kStepData;
      const unsigned n = off / lec::kStepStride;
      auto regs = eeprom_.steps[n].to_registers();
      regs[off % lec::kStepStride] = v;
      eeprom_.steps[n] = lec::StepData::from_registers(std::span<const uint16_t>(regs));
      touched.insert(n);
    } else if (a >= lec::kDirectData && a < lec::kDirectData + direct_.size()) {
      direct_[a - lec::kDirectData] = v;
    } else if (a == lec::kControlWordY10) {
      y10 = v;
    } else if (a == lec::kControlWordY30) {
      y30 = v;
    } else if (a == lec::kDirectStart) {
      start_direct = start_direct || v != 0;  // any non-zero write starts (digest §4)
    }
  }
  for (unsigned n : touched) ++eeprom_.step_writes[n];
  if (!touched.empty()) ++eeprom_generation_;
  if (y10 || y30) {
    const uint16_t new_y = y10.value_or(control_.y10_1f);
    const bool serial = y30 ? (*y30 & 1u) != 0 : control_.serial_mode;
    apply_coils(new_y, serial, y10 && ((*y10 >> 9) & 1u));
  }
  if (start_direct) {
    start_record(lec::StepData::from_registers(std::span<const uint16_t>(direct_)), false, 0);
  }
}

}  // namespace lec6::sim
