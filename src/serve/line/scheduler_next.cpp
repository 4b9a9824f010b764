// Who goes on the line next: the priorities, the turns when a poll waited
// too long, and telemetry's round-robin (scheduler.hpp says the rules).
// The bookkeeping of what comes back is in scheduler.cpp.

#include "line/scheduler.hpp"

#include <algorithm>

namespace lec6::serve {

std::optional<Dispatch> Scheduler::dispatch(Queued q, bool internal, TimePoint now) {
  if (!internal && !q.retry) stats_.wait(q.job.priority, now - q.submitted);
  // The dispatch is built from the flight, not kept in a local beside it:
  // GCC 12 at -O3 took the local's copy of the frame for uninitialised.
  const Flight& f = flight_.emplace(Flight{q.id, std::move(q.job), q.submitted, internal});
  return Dispatch{f.id, f.job.frame, f.job.priority};
}

std::optional<Dispatch> Scheduler::pop(Priority p, TimePoint now) {
  auto& q = queues_[index(p)];
  const bool command = p == Priority::Command;
  while (!q.empty()) {
    // Client commands take turns by source (command_turns.hpp); the rest: first in, first out.
    const auto it = command ? turns_.pick(q) : q.begin();
    Queued taken = std::move(*it);
    q.erase(it);
    // The block it reads may have come in while it waited: no line time, no turn.
    if (answer_from_cache(taken.job, taken.submitted, now)) continue;
    if (command) {
      const JobSource source = taken.job.source;
      turns_.served(source, std::any_of(q.begin(), q.end(), [source](const Queued& x) {
                      return x.job.source == source;
                    }));
    }
    return dispatch(std::move(taken), false, now);
  }
  return std::nullopt;
}

std::optional<Dispatch> Scheduler::next(TimePoint now) {
  if (flight_ || !line_down_.empty() || closed_) return std::nullopt;
  // Stops first, one controller after another (emergency_lane.hpp).
  const auto answering = [this](uint8_t id) {
    const auto h = health_.find(id);
    return h == health_.end() || h->second.consecutive_failures == 0;
  };
  if (auto q = lane_.pop(now, answering)) return dispatch(std::move(*q), false, now);
  if (shutting_down_) return std::nullopt;  // only stops go now
  // A poll that waited too long: the kinds take turns (see the header).
  if (const Starved s = starved(now); s.completion || s.reads) {
    for (int k = 1; k <= kTurns; ++k) {
      const auto turn = static_cast<Turn>((static_cast<int>(last_turn_) + k) % kTurns);
      if (auto d = take_turn(turn, s.reads, now)) {
        last_turn_ = turn;
        return d;
      }
    }
  }
  // Otherwise, or when none of them can go after all: strict priority.
  for (Turn turn : {Turn::Command, Turn::Completion, Turn::Reads}) {
    if (auto d = take_turn(turn, std::nullopt, now)) {
      last_turn_ = turn;
      return d;
    }
  }
  return std::nullopt;
}

// One transaction of this kind, if one is queued (reads: due); `reads`
// names the kind of read that goes first.
std::optional<Dispatch> Scheduler::take_turn(Turn turn, std::optional<Priority> reads,
                                             TimePoint now) {
  switch (turn) {
    case Turn::Command:
      return pop(Priority::Command, now);
    case Turn::Completion:
      return pop(Priority::Completion, now);
    case Turn::Reads:
      return next_read(now, reads);
  }
  return std::nullopt;
}

// Telemetry and background reads; `first` goes first if it can.
std::optional<Dispatch> Scheduler::next_read(TimePoint now, std::optional<Priority> first) {
  // Background reads age: one that waited long enough goes before telemetry,
  // so a line saturated by telemetry still reads its alarm histories.
  const auto& background = queues_[index(Priority::Background)];
  const bool aged =
      !background.empty() && now - background.front().submitted >= config_.background_max_wait;
  const bool background_first = first ? *first == Priority::Background : aged;
  if (!background_first) {
    if (auto d = next_telemetry(now)) return d;
  }
  if (auto d = next_background(now)) return d;
  return background_first ? next_telemetry(now) : std::nullopt;
}

std::optional<Dispatch> Scheduler::next_background(TimePoint now) {
  auto& background = queues_[index(Priority::Background)];
  while (!background.empty()) {
    Queued front = std::move(background.front());
    background.pop_front();
    const auto h = health_.find(front.job.frame.id);
    const bool internal = !front.job.done;
    if (internal && h != health_.end() && h->second.offline) continue;  // skip, not a probe
    return dispatch(std::move(front), internal, now);
  }
  return std::nullopt;
}

// What has waited `poll_max_wait` or more. A completion poll waits from its
// submission; telemetry from its due time (a probe from its probe time); a
// background read from the end of its own `background_max_wait`. Of telemetry
// and background, the one that waited longer (on a tie, telemetry).
Scheduler::Starved Scheduler::starved(TimePoint now) const {
  const TimePoint since = now - config_.poll_max_wait;  // waiting since then or earlier
  Starved s;
  const auto& completion = queues_[index(Priority::Completion)];
  s.completion = !completion.empty() && completion.front().submitted <= since;
  std::optional<TimePoint> oldest;
  const auto consider = [&](Priority p, TimePoint from) {
    if (from > since || (oldest && from >= *oldest)) return;
    s.reads = p;
    oldest = from;
  };
  for (const auto& [id, t] : telemetry_) {
    if (const auto due = read_due(id, t)) consider(Priority::Telemetry, *due);
  }
  if (const auto& q = queues_[index(Priority::Background)]; !q.empty()) {
    const Duration extra =
        std::max(Duration{}, config_.background_max_wait - config_.poll_max_wait);
    consider(Priority::Background, q.front().submitted + extra);
  }
  return s;
}

// When an axis's next read is due: the pass under way's or its period's (an
// offline one: its probe's); nothing when it has no telemetry and answers.
std::optional<TimePoint> Scheduler::read_due(uint8_t id, const Telemetry& t) const {
  const auto h = health_.find(id);
  const bool offline = h != health_.end() && h->second.offline;
  if (t.schedule.telemetry_period <= Duration{} && !offline) return std::nullopt;
  return offline && t.pass.empty() ? h->second.next_probe : t.due;
}

void Scheduler::start_pass(Telemetry& t, TimePoint now) {
  t.pass.clear();
  const uint8_t id = t.schedule.id;
  if (health_[id].offline) {
    t.pass.push_back(Block::Flags);  // the probe: one short read
    return;
  }
  // Blocks another client read recently are fresh enough: skip them.
  const Duration fresh = t.schedule.telemetry_period / 2;
  for (Block b : {Block::Flags, Block::State}) {
    const auto age = cache_.age(id, b, now);
    if (!age || *age >= fresh) t.pass.push_back(b);
  }
  const auto controls_age = cache_.age(id, Block::Controls, now);
  if (!controls_age || *controls_age >= config_.controls_period) t.pass.push_back(Block::Controls);
}

std::optional<Dispatch> Scheduler::next_telemetry(TimePoint now) {
  Telemetry* pick = nullptr;
  TimePoint pick_at = TimePoint::max();
  for (auto& [id, t] : telemetry_) {
    const auto at = read_due(id, t);
    if (!at) continue;
    if (!t.pass.empty()) {  // a pass under way goes on first
      pick = &t;
      break;
    }
    if (*at <= now && *at < pick_at) pick = &t, pick_at = *at;
  }
  if (!pick) return std::nullopt;
  if (pick->pass.empty()) start_pass(*pick, now);
  if (pick->pass.empty()) {  // everything fresh: this period's sample is the cache's
    pick->due += pick->schedule.telemetry_period;
    return next_telemetry(now);
  }
  const Block b = pick->pass.front();
  pick->pass.erase(pick->pass.begin());
  const TimePoint submitted = health_[pick->schedule.id].offline ? now : std::min(pick->due, now);
  return dispatch(Queued{0, internal_read(Priority::Telemetry, pick->schedule.id, b), submitted},
                  true, now);
}

std::optional<TimePoint> Scheduler::wake_at() const {
  std::optional<TimePoint> at = lane_.wake_at();
  if (shutting_down_) return at;
  for (const auto& [id, t] : telemetry_) {
    const auto due = read_due(id, t);
    if (due && (!at || *due < *at)) at = due;
  }
  return at;
}

}  // namespace lec6::serve
