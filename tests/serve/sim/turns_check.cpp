#include "serve/sim/turns_check.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <utility>

namespace lec6::serve::sim_testing {

void TurnsCheck::queued(std::size_t key, JobSource source, uint8_t id) {
  // One that had nothing queued comes in (or back) now; one with a command
  // queued keeps its turn.
  if (queued_[source]++ == 0 || !turn_.contains(source)) turn_[source] = dispatches_;
  waiting_[key] = Waiting{source, id, sent_, false};
}

void TurnsCheck::left(std::size_t key) {
  const auto it = waiting_.find(key);
  if (it == waiting_.end()) return;
  const JobSource source = it->second.source;
  waiting_.erase(it);
  if (--queued_[source] == 0) queued_.erase(source), turn_.erase(source);
}

void TurnsCheck::lost(std::size_t key) {
  if (const auto it = waiting_.find(key); it != waiting_.end()) it->second.resending = true;
}

uint64_t TurnsCheck::turn_of(JobSource source) const {
  const auto it = turn_.find(source);
  return it == turn_.end() ? dispatches_ : it->second;
}

std::string TurnsCheck::on_wire(std::size_t key) {
  const auto it = waiting_.find(key);
  if (it == waiting_.end()) return {};  // not a client command (a stop, a write the lane took)
  Waiting& t = it->second;
  std::string broken;
  if (!std::exchange(t.resending, false)) {  // a resend is not a turn of its own
    broken = broken_by(key, t);
    last_of_[t.source] = sent_++;
  }
  // Served: its source waits its next turn behind the others, if it has more.
  ++dispatches_;
  if (queued_[t.source] > 1) {
    turn_[t.source] = dispatches_;
  } else {
    turn_.erase(t.source);
  }
  return broken;
}

std::string TurnsCheck::broken_by(std::size_t key, const Waiting& t) const {
  const auto last = last_of_.find(t.source);
  for (const auto& [k, x] : waiting_) {
    if (k == key || x.resending || (x.source == t.source && k > key)) continue;
    if (x.source == t.source)
      return fmt::format(
          "command #{} to ID {} went to the wire before command #{} to ID {} of its source, "
          "queued before it",
          key, t.id, k, x.id);
    // x has waited since its submit, and since its source's last turn.
    const auto x_last = last_of_.find(x.source);
    const std::size_t since =
        std::max(x.submitted, x_last == last_of_.end() ? 0 : x_last->second + 1);
    if (last != last_of_.end() && last->second >= since)
      return fmt::format(
          "command #{} to ID {}: its source's second turn while command #{} to ID {} of another "
          "one waited",
          key, t.id, k, x.id);
  }
  // The source served least recently (or come in earliest) goes; on a tie,
  // the older command. Keys grow in the order of the queue (but for a
  // resend, at its front: not judged).
  const uint64_t turn = turn_of(t.source);
  for (const auto& [k, x] : waiting_) {
    if (k == key || x.resending || x.source == t.source) continue;
    const uint64_t other = turn_of(x.source);
    if (other < turn || (other == turn && k < key))
      return fmt::format(
          "command #{} to ID {} went ahead of command #{} to ID {}, whose turn came first (its "
          "source's turn: dispatch {}, against {}{})",
          key, t.id, k, x.id, other, turn, other == turn ? ", and it is the older" : "");
  }
  return {};
}

}  // namespace lec6::serve::sim_testing
