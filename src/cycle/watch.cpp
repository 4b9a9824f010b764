#include "lec6/cycle/watch.hpp"

#include <fmt/format.h>

#include "lec6/lec/units.hpp"

namespace lec6::cycle {

Outcome outcome_of(client::MoveOutcome o) noexcept {
  switch (o) {
    case client::MoveOutcome::Reached:
      return Outcome::Reached;
    case client::MoveOutcome::Pushed:
      return Outcome::Pushed;
    case client::MoveOutcome::PushMissed:
      return Outcome::PushMissed;
    case client::MoveOutcome::Stopped:
      return Outcome::Stopped;
    case client::MoveOutcome::Alarm:
      return Outcome::Alarm;
    case client::MoveOutcome::Deadline:
      return Outcome::Timeout;
    case client::MoveOutcome::NotStarted:
      return Outcome::NotStarted;
  }
  return Outcome::Stopped;
}

Watch Watch::motion(const Step& step, const client::MoveStart& start, TimePoint deadline) {
  Watch w(step);
  w.begun_ = start.at;
  w.until_ = deadline;
  w.completion_.emplace(start, deadline);
  return w;
}

Watch Watch::timed(const Step& step, TimePoint now) {
  Watch w(step);
  w.begun_ = now;
  w.until_ = now + (step.kind == Step::Kind::Dwell ? step.dwell : step.timeout);
  return w;
}

std::optional<TimePoint> Watch::wake_at() const {
  if (step_->kind == Step::Kind::Dwell) return until_;
  return std::nullopt;
}

std::optional<ActivityResult> Watch::feed_time(TimePoint now) {
  if (step_->kind != Step::Kind::Dwell) return std::nullopt;
  if (now < until_) return std::nullopt;
  return ActivityResult{Outcome::Done, fmt::format("{:.3f} s", to_seconds(now - begun_))};
}

std::optional<ActivityResult> Watch::feed(const client::Poll& poll) {
  if (completion_) {
    auto r = completion_->feed(poll);
    if (!r) return std::nullopt;
    move_ = *r;
    return ActivityResult{outcome_of(r->outcome), r->describe()};
  }
  if (step_->kind == Step::Kind::Dwell) return feed_time(poll.at);
  const Step& s = *step_;
  if (s.condition_met(poll.flags, poll.state.position_001mm)) {
    return ActivityResult{Outcome::Done,
                          fmt::format("after {:.3f} s at {} mm", to_seconds(poll.at - begun_),
                                      lec::format_mm(poll.state.position_001mm))};
  }
  if (poll.flags.alarm()) {
    return ActivityResult{Outcome::Alarm, fmt::format("ALARM = 1 while waiting ({})", s.text)};
  }
  if (poll.at >= until_) {
    return ActivityResult{
        Outcome::Timeout,
        fmt::format("not met within {:.3f} s (axis at {} mm, flags {})",
                    to_seconds(until_ - begun_), lec::format_mm(poll.state.position_001mm),
                    poll.flags.describe())};
  }
  return std::nullopt;
}

}  // namespace lec6::cycle
