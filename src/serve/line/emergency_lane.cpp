#include "line/emergency_lane.hpp"

#include <utility>
#include <vector>

#include "line/scheduler.hpp"

namespace lec6::serve {

bool EmergencyLane::push(Queued q) {
  Controller& c = controllers_[q.job.frame.id];
  for (Queued& waiting : c.jobs) {
    if (waiting.retry || !(waiting.job.frame.pdu == q.job.frame.pdu)) continue;
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
  if (c.jobs.empty()) c.waiting_since = std::max(q.submitted, c.not_before);
  c.jobs.push_back(std::move(q));
  ++size_;
  return false;
}

void EmergencyLane::retry(Queued q, bool answering, TimePoint now) {
  Controller& c = controllers_[q.job.frame.id];
  q.retry = true;
  c.not_before = answering ? now : now + backoff_;
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
  last_ = it->first;
  last_answering_ = answering;
  if (c.jobs.empty()) {
    controllers_.erase(it);
  } else {
    c.waiting_since = std::max(c.waiting_since, c.not_before);
  }
  return q;
}

std::optional<Queued> EmergencyLane::pop(TimePoint now,
                                         const std::function<bool(uint8_t)>& answering) {
  if (size_ == 0) return std::nullopt;
  // Round robin from the controller after the last one served.
  std::vector<std::map<uint8_t, Controller>::iterator> order;
  for (auto it = controllers_.upper_bound(last_); it != controllers_.end(); ++it)
    order.push_back(it);
  for (auto it = controllers_.begin(); it != controllers_.end() && it->first <= last_; ++it)
    order.push_back(it);
  std::optional<std::map<uint8_t, Controller>::iterator> first_answering, first_silent;
  for (auto it : order) {
    const Controller& c = it->second;
    if (c.jobs.empty() || c.not_before > now) continue;
    if (answering(it->first)) {
      if (!first_answering) first_answering = it;
    } else if (!first_silent) {
      first_silent = it;
    }
  }
  // A non-answering controller that waited its backoff gets one exchange
  // after each answering one: it is never starved, and costs the answering
  // ones at most one exchange each time.
  if (first_silent &&
      (!first_answering ||
       (last_answering_ && now - (*first_silent)->second.waiting_since >= backoff_)))
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

std::vector<Queued> EmergencyLane::take_all() {
  std::vector<Queued> all;
  for (auto& [id, c] : controllers_)
    for (auto& q : c.jobs) all.push_back(std::move(q));
  controllers_.clear();
  size_ = 0;
  return all;
}

}  // namespace lec6::serve
