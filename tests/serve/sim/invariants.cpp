// The line simulation's invariants (line_sim.hpp; world.hpp), but the
// command turns' (turns_check.hpp): the stops' bound, the holds, the coils,
// the cache's answers, the turns' memory, every job answered.

#include <fmt/format.h>

#include <algorithm>

#include "lec6/lec/memory_map.hpp"
#include "serve/sim/world.hpp"

namespace lec6::serve::sim_testing::detail {

// Invariant 9: the scheduler's memory of turns stays bounded however many
// sources come and go (a connection per request): once a command is
// queued, it knows at most kSourcesBeyondQueue sources more than it has
// commands queued. Counts the submits at which it forgot idle ones.
void World::check_turns_memory(std::size_t key, std::size_t known_before,
                               std::size_t depth_before) {
  const std::size_t known = s_->command_sources();
  const std::size_t depth = s_->queue_depth()[index(Priority::Command)];
  if (known < known_before) ++run_.forgets;
  if (depth > depth_before && known > depth + kSourcesBeyondQueue)
    violation(
        fmt::format("command #{} queued: the scheduler keeps turns for {} sources, {} "
                    "commands queued",
                    key, known, depth));
}

// Invariant 8: a read answered from the cache is no older than its
// max_cache_age allows, nor than what its connection saw (Job::not_before).
// Counts those answered at submit and those answered when their turn came.
void World::from_cache(std::size_t key, const Tracked& t, const JobResult& r) {
  ++cache_answers_;
  // At submit, the answer is the submit's instant; a read queued first is
  // answered at a later one (an exchange refreshed its block meanwhile).
  ++(r.finished > r.submitted ? run_.cache_at_turn : run_.cache_at_submit);
  if (t.write || r.finished - r.started > t.max_cache_age || r.started < t.not_before)
    violation(
        fmt::format("job #{} to ID {} answered from the cache with a block read {:.1f} ms "
                    "before (max {:.1f} ms){}",
                    key, t.id, ms(r.finished - r.started), ms(t.max_cache_age),
                    r.started < t.not_before ? ", older than its connection saw" : ""));
}

// Emergency lane bound (emergency_lane.hpp): the exchange on the wire,
// then per round one exchange for each other controller with a stop: an
// answered one for a clean controller; a lost one for a noisy or flapping
// one (it counts as answering until an exchange fails: nobody can know
// before); and one lost exchange for all the dead ones together (they
// wait their backoff behind the answering ones). One round per stop to
// the same controller queued ahead of it.
Duration World::stop_bound(const Tracked& t) const {
  const Duration answered =
      exchange_time(modbus::ReadRegistersRequest{lec::kStateData, 7}, 1) * 3 / 2;
  // A lost exchange, and the quiet the line keeps after it before a write
  // moved into the lane ahead of the stop (exchange()).
  const Duration lost = 2 * kTimeout + timing_.wire_time(17);
  Duration round = lost;  // the non-answering ones' turn
  for (const auto& [id, d] : devices_) {
    if (id == t.id) continue;
    // A dead controller not yet tried counts as answering: nobody knows.
    const bool known_silent = s_->health(id).consecutive_failures > 0;
    if (d.kind == Kind::Dead && known_silent) continue;
    round += d.kind == Kind::Clean ? answered : lost;
  }
  return lost + static_cast<int64_t>(t.same_queued + 1) * round + 1ms;
}

Duration World::exchange_time(const modbus::Request& r, uint8_t id) const {
  const auto q = modbus::encode_request({id, r});
  return timing_.transaction_limit(q ? q->size() : 8, modbus::expected_response_length(r));
}

// Invariant 5: a HOLD answered done holds a clean axis: at rest after its
// deceleration (jog 50 mm/s at 1000 mm/s2: 50 ms) plus one transaction,
// unless another write to that controller came after it.
void World::check_holds() {
  for (auto it = holds_.begin(); it != holds_.end();) {
    if (clock_ - it->at < 100ms) {
      ++it;
      continue;
    }
    Device& d = devices_[it->id];
    const bool later_write = d.last_write_key != it->key;
    if (!later_write && d.twin && d.twin->state(clock_).speed_mm_s != 0)
      violation(fmt::format("ID {} still moves at {} mm/s {:.0f} ms after its HOLD was answered",
                            it->id, d.twin->state(clock_).speed_mm_s, ms(clock_ - it->at)));
    it = holds_.erase(it);
  }
}

// Invariant 7: no answer says success where the twin disagrees. Each coil
// of a controller that hears only what it answers (clean or flapping; a
// noisy one hears writes whose replies are lost) holds what the last write
// answered done set it to.
void World::check_coils() {
  for (auto& [id, d] : devices_) {
    if (!d.twin || d.kind == Kind::Noisy || d.coils.empty()) continue;
    const auto r = d.twin->handle(
        modbus::ReadBitsRequest{modbus::FunctionCode::ReadCoils, 0x10, 0x30}, clock_);
    const auto* bits = std::get_if<modbus::ReadBitsResponse>(&r);
    if (!bits) {
      violation(fmt::format("ID {}: the twin did not answer a read of its coils", id));
      continue;
    }
    for (const auto& [coil, want] : d.coils) {
      if (coil < 0x10 || coil >= 0x40) continue;
      const bool is = bits->bit(coil - 0x10u);
      if (is != want.first)
        violation(
            fmt::format("ID {}: coil {:02X}H is {} on the twin, but the last write answered "
                        "done (#{}) set it to {}",
                        id, coil, is ? 1 : 0, want.second, want.first ? 1 : 0));
    }
  }
}

void World::final_checks() {
  check_coils();
  for (const auto& [key, t] : tracked_) {
    if (t.answers == 0) violation(fmt::format("job #{} to ID {} never answered", key, t.id));
  }
  run_.cache_hits = s_->stats(clock_).cache_hits;
  if (run_.cache_hits != cache_answers_)
    violation(
        fmt::format("the scheduler counts {} cache hits; the clients got {} answers from "
                    "the cache",
                    run_.cache_hits, cache_answers_));
  run_.jog_sources = jog_sources_.size();
}

void World::violation(const std::string& what) {
  note(6, run_.violations.size(), [&] { return "VIOLATION " + what; });
  run_.violations.push_back(what);
}

}  // namespace lec6::serve::sim_testing::detail
