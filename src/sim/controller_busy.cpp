// The twin controller's BUSY (digest §5–§6 and the field quirks of
// ActuatorConfig): starts taken now or after a BUSY delay, the shortest BUSY
// pulse, and the truth record of every start (OperationRecord) that tests
// judge a master's completion logic against.

#include "lec6/sim/controller.hpp"

#include <cmath>

namespace lec6::sim {

// A start was taken: it begins now, or after the configured BUSY delay
// (ActuatorConfig::busy_delay). A later start replaces a pending one.
void Controller::take_start(PendingStart start) {
  if (!records_.empty() && !records_.back().busy_rose && pending_) records_.back().cancelled = true;
  records_.push_back(OperationRecord{start.homing, now_, {}, {}, false, false, {}});
  if (records_.size() > kOperationRecords) records_.pop_front();
  if (config_.busy_delay <= Duration::zero()) {
    pending_.reset();
    begin(start);
    return;
  }
  start.at = now_ + config_.busy_delay;
  // Without target_update_late the registers show the new target at once,
  // while BUSY and the outputs still show the old operation.
  if (!start.homing && !config_.target_update_late) {
    const bool absolute = start.data.movement_mode == lec::MovementMode::Absolute;
    const int64_t target =
        absolute ? start.data.position_001mm : start.base_target + start.data.position_001mm;
    if (!refusal(start.data, start.is_step, target)) {
      target_001mm_ = target;
      step_no_ = start.step_no;
    }
  }
  pending_ = start;
}

void Controller::begin(const PendingStart& start) {
  if (start.homing) {
    start_homing();
  } else {
    start_record(start.data, start.is_step, start.step_no, start.base_target);
  }
}

// BUSY rises for a homing or a move that was accepted.
void Controller::begin_busy() {
  if (busy_ && !records_.empty()) {
    // The running operation continues into this one: it never ended on its own.
    for (auto it = records_.rbegin() + 1; it != records_.rend(); ++it) {
      if (it->busy_rose && !it->busy_fell) it->superseded = true;
    }
  }
  if (!busy_) busy_from_mm_ = kin().position;
  busy_ = true;
  busy_hold_.reset();
  busy_rose_at_ = now_;
  if (!records_.empty() && !records_.back().busy_rose) records_.back().busy_rose = now_;
}

// The operation ended on its own with `inp`; BUSY falls, unless the shortest
// pulse (busy_min) has not passed yet: then BUSY stays up, INP 0, until it has.
void Controller::complete(bool inp) {
  op_ = Op{};
  const TimePoint min_until = busy_rose_at_ + config_.busy_min;
  if (config_.busy_min > Duration::zero() && now_ < min_until) {
    busy_hold_ = BusyHold{min_until, inp};
    clear_inp();
    return;
  }
  drop_busy();
  settle_inp(inp);
}

void Controller::settle_inp(bool inp) {
  if (inp && !pressing_ && config_.inp_delay > Duration::zero()) {
    inp_ = false;
    inp_due_ = now_ + config_.inp_delay;
    return;
  }
  inp_ = inp;
  inp_due_.reset();
}

// BUSY falls now (an end, a stop, an alarm).
void Controller::drop_busy() {
  if (busy_) {
    for (auto it = records_.rbegin(); it != records_.rend(); ++it) {
      if (it->busy_rose && !it->busy_fell && !it->superseded) {
        it->busy_fell = now_;
        break;
      }
    }
  }
  if (busy_) travelled_mm_ += std::abs(kin().position - busy_from_mm_);
  busy_ = false;
  busy_hold_.reset();
}

// A pending start that a stop, servo off or alarm cancels before BUSY rose.
void Controller::cancel_pending() {
  if (!pending_) return;
  pending_.reset();
  if (!records_.empty() && !records_.back().busy_rose) records_.back().cancelled = true;
}

}  // namespace lec6::sim
