#include "line/emergency_lane.hpp"

#include <utility>
#include <vector>

#include "lec6/lec/memory_map.hpp"
#include "line/scheduler.hpp"

namespace lec6::serve {

bool EmergencyLane::push(Queued q, std::optional<uint8_t> under) {
  const uint8_t key = under.value_or(q.job.frame.id);
  Controller& c = controllers_[key];
  c.not_before = std::max(c.not_before, backoff_until_[key]);
  // Joins only the last one queued: joining an earlier one would reorder the
  // writes (RESET <- 1 then <- 0 joined to an earlier 0 leaves RESET at 1).
  if (!c.jobs.empty()) {
    Queued& waiting = c.jobs.back();
    if (waiting.retry || !(waiting.job.frame == q.job.frame)) {
      c.jobs.push_back(std::move(q));
      ++size_;
      return false;
    }
    // Joins: one exchange answers both submitters.
    auto first = std::move(waiting.job.done);
    auto second = std::move(q.job.done);
    waiting.job.done = [first = std::move(first), second = std::move(second)](const JobResult& r) {
      if (first) first(r);
      if (second) second(r);
    };
    waiting.job.attempts = std::max(waiting.job.attempts, q.job.attempts);
    return true;
  }
  c.waiting_since = std::max(q.submitted, c.not_before);
  c.jobs.push_back(std::move(q));
  ++size_;
  return false;
}

namespace {

// A write of levels (coils, the control words): the same one twice in a row
// is the same as once. A D9100 start is not (each is a start).
bool writes_levels(const modbus::Request& r) {
  if (std::holds_alternative<modbus::WriteCoilRequest>(r) ||
      std::holds_alternative<modbus::WriteCoilsRequest>(r))
    return true;
  const auto* w = std::get_if<modbus::WriteRegistersRequest>(&r);
  return w && w->start >= lec::kControlWordY10 && w->start + w->count <= lec::kControlWordY30 + 1;
}

}  // namespace

void EmergencyLane::push_in_order(Queued q, uint8_t under) {
  if (writes_levels(q.job.frame.pdu)) {
    push(std::move(q), under);  // joins an identical last one
    return;
  }
  Controller& c = controllers_[under];
  c.not_before = std::max(c.not_before, backoff_until_[under]);
  if (c.jobs.empty()) c.waiting_since = std::max(q.submitted, c.not_before);
  c.jobs.push_back(std::move(q));
  ++size_;
}

void EmergencyLane::retry(Queued q, bool answering, TimePoint now) {
  Controller& c = controllers_[q.job.frame.id];
  q.retry = true;
  c.not_before = answering ? now : now + backoff_;
  // Kept beyond this stop: the next one to this controller backs off too.
  backoff_until_[q.job.frame.id] = c.not_before;
  c.waiting_since = c.not_before;
  c.jobs.push_front(std::move(q));
  ++size_;
}

std::optional<Queued> EmergencyLane::take(std::map<uint8_t, Controller>::iterator it,
                                          bool answering) {
  Controller& c = it->second;
  Queued q = std::move(c.jobs.front());
  c.jobs.pop_front();
  --size_;
  (answering ? last_answering_ : last_silent_) = it->first;
  last_was_answering_ = answering;
  if (c.jobs.empty()) {
    controllers_.erase(it);
  } else {
    c.waiting_since = std::max(c.waiting_since, c.not_before);
  }
  return q;
}

// The first controller after `last` (round robin) with a stop ready now
// that is (or is not) answering.
std::optional<std::map<uint8_t, EmergencyLane::Controller>::iterator> EmergencyLane::next_after(
    uint8_t last, bool want_answering, TimePoint now,
    const std::function<bool(uint8_t)>& answering) {
  const auto ready = [&](const auto& it) {
    return !it->second.jobs.empty() && it->second.not_before <= now &&
           answering(it->first) == want_answering;
  };
  for (auto it = controllers_.upper_bound(last); it != controllers_.end(); ++it)
    if (ready(it)) return it;
  for (auto it = controllers_.begin(); it != controllers_.end() && it->first <= last; ++it)
    if (ready(it)) return it;
  return std::nullopt;
}

std::optional<Queued> EmergencyLane::pop(TimePoint now,
                                         const std::function<bool(uint8_t)>& answering) {
  if (size_ == 0) return std::nullopt;
  // Two rounds, each with its own cursor: the answering controllers', and
  // the non-answering ones' (a turn of the latter must not restart the
  // former's round).
  const auto first_answering = next_after(last_answering_, true, now, answering);
  const auto first_silent = next_after(last_silent_, false, now, answering);
  // A non-answering controller that waited its backoff gets one exchange
  // where the answering controllers' round begins again: it is never
  // starved, and costs each answering controller's stop at most one
  // exchange.
  const bool round_begins =
      first_answering && (*first_answering)->first <= last_answering_ && last_was_answering_;
  if (first_silent && (!first_answering ||
                       (round_begins && now - (*first_silent)->second.waiting_since >= backoff_)))
    return take(*first_silent, false);
  if (first_answering) return take(*first_answering, true);
  return std::nullopt;
}

std::optional<TimePoint> EmergencyLane::wake_at() const {
  std::optional<TimePoint> at;
  for (const auto& [id, c] : controllers_) {
    if (c.jobs.empty()) continue;
    if (!at || c.not_before < *at) at = c.not_before;
  }
  return at;
}

bool EmergencyLane::ready(TimePoint now) const {
  for (const auto& [id, c] : controllers_)
    if (!c.jobs.empty() && c.not_before <= now) return true;
  return false;
}

std::vector<Queued> EmergencyLane::take_if(const std::function<bool(const Queued&)>& pred) {
  std::vector<Queued> taken;
  for (auto it = controllers_.begin(); it != controllers_.end();) {
    auto& jobs = it->second.jobs;
    for (auto j = jobs.begin(); j != jobs.end();) {
      if (pred(*j)) {
        taken.push_back(std::move(*j));
        j = jobs.erase(j);
        --size_;
      } else {
        ++j;
      }
    }
    it = jobs.empty() ? controllers_.erase(it) : std::next(it);
  }
  return taken;
}

std::vector<Queued> EmergencyLane::take_all() {
  std::vector<Queued> all;
  for (auto& [id, c] : controllers_)
    for (auto& q : c.jobs) all.push_back(std::move(q));
  controllers_.clear();
  size_ = 0;
  return all;
}

}  // namespace lec6::serve
