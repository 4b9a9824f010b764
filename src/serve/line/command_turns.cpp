#include "line/command_turns.hpp"

#include <atomic>
#include <unordered_set>

namespace lec6::serve {

JobSource new_job_source() {
  static std::atomic<JobSource> next{1};
  return next.fetch_add(1, std::memory_order_relaxed);
}

void CommandTurns::queued(JobSource source, bool waiting) {
  if (waiting) {
    turn_of_.try_emplace(source, served_);
  } else {
    turn_of_[source] = served_;
  }
}

std::deque<Queued>::iterator CommandTurns::pick(std::deque<Queued>& q) {
  if (q.front().retry) return q.begin();
  auto best = q.begin();
  uint64_t best_turn = UINT64_MAX;
  for (auto it = q.begin(); it != q.end(); ++it) {
    const auto known = turn_of_.find(it->job.source);
    // Not known (forgotten while queued: see queued()): as if it came in now.
    const uint64_t turn = known == turn_of_.end() ? served_ : known->second;
    if (turn < best_turn) {  // strictly: the oldest job of its source
      best = it;
      best_turn = turn;
    }
  }
  return best;
}

void CommandTurns::served(JobSource source, bool more) {
  ++served_;
  if (more) {
    turn_of_[source] = served_;
  } else {
    turn_of_.erase(source);
  }
}

void CommandTurns::forget_idle(const std::deque<Queued>& q) {
  std::unordered_set<JobSource> waiting;
  for (const Queued& x : q) waiting.insert(x.job.source);
  std::erase_if(turn_of_, [&](const auto& e) { return !waiting.contains(e.first); });
}

}  // namespace lec6::serve
