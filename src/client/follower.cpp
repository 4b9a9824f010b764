#include "lec6/client/follower.hpp"

#include <fmt/format.h>

#include "lec6/lec/alarms.hpp"

namespace lec6::client {

Follower::Follower(Actuator& axis, FollowOptions options)
    : axis_(axis), options_(std::move(options)) {}

void Follower::judge(const lec::StatusFlags& flags) {
  flags_ = flags;
  if (flags.alarm()) {
    const auto codes = axis_.active_alarms(flags);
    std::string text;
    for (uint8_t c : codes)
      text += fmt::format("{}{} ({})", text.empty() ? "" : ", ", c, lec::alarm_meaning(c));
    throw AlarmError(codes, fmt::format("alarm while following: {}; {}",
                                        text.empty() ? "no code in the history" : text,
                                        lec::alarm_clear_hint(codes)));
  }
}

void Follower::apply(int32_t position_001mm) {
  if (!last_) {
    DirectMove m = options_.move;
    m.position_001mm = position_001mm;
    m.relative = false;
    m.pushing_force_pct.reset();
    last_ = axis_.start(m);
    last_->start.may_be_running = true;  // later setpoints may find it running
  } else {
    last_ = axis_.retarget(position_001mm, options_.move.speed_mm_s);
  }
  ++applied_;
  if (options_.check_every > 0 && ++since_check_ >= options_.check_every) look();
}

void Follower::look() {
  since_check_ = 0;
  ++checks_;
  controls_ = axis_.client().read_controls();
  judge(axis_.client().read_flags());
}

lec::StatusFlags Follower::check() {
  look();
  state_ = axis_.client().read_state();
  return flags_;
}

std::optional<MoveResult> Follower::finish(TimePoint deadline, const WaitOptions& wait) {
  if (!last_) return std::nullopt;
  return axis_.wait(*last_, deadline, wait);
}

}  // namespace lec6::client
