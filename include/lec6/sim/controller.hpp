#pragma once
// One simulated LEC□6 controller with its actuator (digest §3–§6), sans-I/O.
//
// The model never reads a clock: every call carries the time point it happens
// at, and the model advances itself to it (time only moves forward; an earlier
// time point acts at the model's current time). Between calls nothing runs:
// the carriage follows an analytic MotionProfile, and events (SVRE rising,
// a move ending, the carriage meeting the workpiece) are found analytically
// and applied in order by advance().
//
// Thread safety: none inside; a Controller is used by one thread at a time (its Bus's).

#include <array>
#include <cstdint>
#include <deque>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "lec6/clock.hpp"
#include "lec6/lec/alarms.hpp"
#include "lec6/lec/equipment_name.hpp"
#include "lec6/lec/flags.hpp"
#include "lec6/lec/state_data.hpp"
#include "lec6/lec/step_data.hpp"
#include "lec6/modbus/pdu.hpp"
#include "lec6/sim/behaviour.hpp"
#include "lec6/sim/motion_profile.hpp"

namespace lec6::sim {

// What the controller keeps in EEPROM (digest §6 "Memory"); the rest is RAM.
struct Eeprom {
  static constexpr std::size_t kSteps = 64;
  std::array<lec::StepData, kSteps> steps{};
  lec::AlarmHistory alarms;
  lec::EquipmentName name;
  // Write transactions per step (a step counts once per FC10 touching it);
  // the manual's endurance guideline is 100 000 writes (§3).
  std::array<uint32_t, kSteps> step_writes{};
  bool operator==(const Eeprom&) const = default;
};

// Problems with a configuration, one message each; empty when it is usable.
std::vector<std::string> validate(const ActuatorConfig& config);

// What one start (a step, a direct operation or a return to origin) really
// did, as only the twin knows it: the truth tests judge a master's completion
// logic against (issue 12), and a record for tools.
struct OperationRecord {
  bool homing = false;
  TimePoint taken;                       // the controller acted on the start request
  std::optional<TimePoint> busy_rose;    // the operation began (BUSY = 1)
  std::optional<TimePoint> busy_fell;    // it ended (BUSY = 0): done, stopped or alarm
  bool superseded = false;               // a later start took over while it ran
  bool cancelled = false;                // stopped before BUSY rose (pending start)
  std::optional<uint8_t> refused_alarm;  // refused with this alarm when it would have begun
};

class Controller {
 public:
  // Powers on at `power_on`. EEPROM contents come from `eeprom` when given
  // (a state file), else factory state (blank steps, empty history, the
  // configured equipment name). Throws lec6::InvalidArgument for a config
  // that validate() refuses.
  explicit Controller(const ActuatorConfig& config = {}, TimePoint power_on = TimePoint{},
                      const std::optional<Eeprom>& eeprom = std::nullopt);

  // ---- the serial interface ----------------------------------------------
  // Acts on one decoded request addressed to this controller at time `t` and
  // returns its reply (an ExceptionResponse when refused, digest §3). The
  // write is applied first, then the reply is built: a start has already set
  // BUSY and cleared INP in a reply read after it. The memory map onto the
  // inputs and outputs below is in sim/register_adapter.cpp.
  modbus::Response handle(const modbus::Request& request, TimePoint t);

  // ---- the controller's inputs, in the manual's terms ---------------------
  // These act at now(); handle() advances to its request's time first.
  //
  // New Y10–Y1F and Y30 values (coils or D90C1/D90C2); the controller acts
  // on their edges: SVON, RESET, HOLD, SETUP, DRIVE (with IN0–IN5), JOG±.
  struct ControlWrite {
    lec::ControlFlags flags;
    // The write set SVON ← 1, even if it was on already: a servo-on after
    // an EMG stop needs a new SVON write (digest §6).
    bool svon_written = false;
  };
  void write_control(const ControlWrite& write);
  // Direct-operation data D9102–D910F (RAM), by register index.
  static constexpr std::size_t kDirectDataRegisters = 16;
  const std::array<uint16_t, kDirectDataRegisters>& direct_data() const { return direct_; }
  void write_direct_data(std::size_t index, uint16_t value);
  // D9100 written non-zero: starts the direct-operation data as a move.
  void start_direct();
  // Step data written by one transaction (step number → new contents): each
  // step counts one EEPROM write.
  void write_steps(const std::map<unsigned, lec::StepData>& steps);

  // ---- external inputs ---------------------------------------------------
  // The EMG stop input (digest §6): on = stop at once, SVRE 0, ESTOP 1;
  // off = ESTOP 0, servo stays off until the next SVON ← 1 write.
  void set_estop(bool on, TimePoint t);
  // The controller raises alarm `code` at `t` as if it had found the fault
  // itself (fault injection: lec cycle's faults): a motion stops with the
  // alarm's deceleration, BUSY falls, ALARM rises; RESET clears the codes
  // RESET clears (alarm_resettable).
  void inject_alarm(uint8_t code, TimePoint t);

  // ---- time ---------------------------------------------------------------
  // Applies every event up to `t` (SVRE delay, move ends, contact, alarms).
  void advance(TimePoint t);
  TimePoint now() const { return now_; }
  // The next instant the model changes a flag by itself, if one is pending.
  std::optional<TimePoint> next_event() const;

  // ---- what the master could read, at time t (advances to t) --------------
  lec::StatusFlags status(TimePoint t);
  lec::StateData state(TimePoint t);
  lec::ControlFlags control() const { return control_; }
  // Reported position (mm, the controller's coordinate) and the carriage's
  // physical state (homed coordinate of the config).
  double position_mm(TimePoint t);
  Kinematics physical(TimePoint t);
  double thrust_pct(TimePoint t);
  // Metres travelled so far (wear_pct_per_m applies to it).
  double travelled_m() const { return travelled_mm_ / 1000.0; }
  // The alarm present (X4F), if any, as of now() (does not advance).
  std::optional<uint8_t> alarm() const { return alarm_; }
  // A start taken whose BUSY has not risen yet (ActuatorConfig::busy_delay).
  bool start_pending() const { return pending_.has_value(); }
  // The last starts, oldest first (at most kOperationRecords).
  static constexpr std::size_t kOperationRecords = 32;
  const std::deque<OperationRecord>& operations() const { return records_; }

  // ---- EEPROM -----------------------------------------------------------
  const Eeprom& eeprom() const { return eeprom_; }
  void restore_eeprom(const Eeprom& e);
  // Bumped on every EEPROM change, so a program knows when to save.
  uint64_t eeprom_generation() const { return eeprom_generation_; }

  const ActuatorConfig& config() const { return config_; }
  // Puts the workpiece at `workpiece_mm` (homed coordinate), or takes it
  // away (nullopt), as of `t`. Only while the carriage is at rest and no
  // operation runs: moving a workpiece under a moving carriage has no physical
  // meaning. Throws InvalidArgument (with the reason) otherwise.
  void set_workpiece(std::optional<double> workpiece_mm, TimePoint t);

 private:
  enum class OpKind { None, Homing, Move, Jog, JogStop, Stalled };
  enum class MovePhase { Approach, Push };

  // A started step or direct operation, in physical mm.
  struct MoveSpec {
    MoveLimits approach;
    bool pushing = false;
    double target_phys = 0.0;  // target or pushing start
    double push_end_phys = 0.0;
    MoveLimits push;
    double moving_force = 100.0;
    double pushing_force = 0.0;
    double trigger_level = 0.0;
  };

  struct Op {
    OpKind kind = OpKind::None;
    bool held = false;        // HOLD: decelerated and suspended
    int homing_phase = 0;     // 0: toward the homing end, 1: to the origin
    bool stop_first = false;  // a retarget decelerating to rest first (Retarget::StopThenStart)
    MovePhase phase = MovePhase::Approach;
    MoveSpec move;
    int jog_dir = 0;
    TimePoint stall_alarm_at{};
    uint8_t stall_alarm = 0;
    double stall_thrust = 0.0;
  };

  enum class EventKind { Svre, PhaseEnd, Contact, StallAlarm, StartDue, BusyMinEnd, InpDue };

  // A start taken but not begun yet (busy_delay).
  struct PendingStart {
    bool homing = false;
    lec::StepData data;
    bool is_step = false;
    uint8_t step_no = 0;
    int64_t base_target = 0;  // D9004 when taken: INC counts from it
    TimePoint at;             // when BUSY rises
  };
  // BUSY held up after the operation ended (busy_min), and the INP it ends with.
  struct BusyHold {
    TimePoint until;
    bool inp = false;
  };
  struct Event {
    TimePoint at;
    EventKind kind;
  };

  std::optional<Event> next_pending() const;
  void fire(const Event& e);
  std::optional<TimePoint> contact_time(TimePoint from) const;

  // Operations.
  Kinematics kin() const { return profile_.at(now_); }
  void servo_off();
  void cancel_op(double deceleration);
  void take_start(PendingStart start);
  void begin(const PendingStart& start);
  void start_homing();
  double homing_end() const {
    return config_.homing_direction == ActuatorConfig::HomingDirection::MaxEnd
               ? config_.stroke_max_mm
               : config_.stroke_min_mm;
  }
  bool setup_blocks_starts() const;
  void start_record(const lec::StepData& data, bool is_step, uint8_t step_no, int64_t base_target);
  std::optional<uint8_t> refusal(const lec::StepData& data, bool is_step, int64_t target) const;
  void begin_busy();
  void cancel_pending();
  void complete(bool inp);
  void settle_inp(bool inp);  // INP at an operation's end (ActuatorConfig::inp_delay)
  void clear_inp() {
    inp_ = false;
    inp_due_.reset();
  }
  void drop_busy();
  void plan_phase();
  void hold_on();
  void hold_off();
  void update_jog();
  void raise_alarm(uint8_t code);
  void reset();
  double current_decel() const;
  double reported(double phys) const { return phys - offset_mm_; }
  int32_t to_001mm(double mm) const;

  ActuatorConfig config_;
  Eeprom eeprom_;
  uint64_t eeprom_generation_ = 0;
  TimePoint now_{};

  // RAM: flags, direct data, state.
  lec::ControlFlags control_{};
  std::array<uint16_t, kDirectDataRegisters> direct_{};
  bool svre_ = false;
  std::optional<TimePoint> svre_at_;
  bool seton_ = false;
  bool inp_ = false;
  std::optional<TimePoint> inp_due_;  // INP rises then (inp_delay)
  bool busy_ = false;
  bool estop_ = false;
  bool pressing_ = false;
  double pressing_force_ = 0.0;
  std::optional<uint8_t> alarm_;
  uint8_t out_ = 0;
  uint16_t step_no_ = 0;
  int64_t target_001mm_ = 0;
  std::optional<RangeMm> area_mm_;  // reported coordinate

  // Field quirks and the truth record.
  std::optional<PendingStart> pending_;
  std::optional<BusyHold> busy_hold_;
  TimePoint busy_rose_at_{};
  std::deque<OperationRecord> records_;

  // Physics.
  MotionProfile profile_;
  double offset_mm_ = 0.0;  // reported = physical − offset
  int workpiece_side_ = 1;  // which side of the workpiece the carriage is on
  Op op_;
  // Wear (ActuatorConfig::wear_pct_per_m): travel counted from BUSY up to down.
  double travelled_mm_ = 0.0;
  double busy_from_mm_ = 0.0;
  double wear_factor() const { return 1.0 + config_.wear_pct_per_m / 100.0 * travelled_m(); }
};

}  // namespace lec6::sim
