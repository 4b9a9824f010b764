// The line simulation (line_sim.hpp): a plant drawn from a seed, run on a
// virtual clock through the real scheduler and gateway rule, the twin's
// controllers answering (world.hpp: this file is the loop, the gateway and
// the wire).

#include <fmt/format.h>

#include <algorithm>

#include "lec6/client/interrupt.hpp"
#include "lec6/lec/memory_map.hpp"
#include "serve/sim/world.hpp"

namespace lec6::serve::sim_testing {
namespace detail {
namespace {

const client::TransportError kNoReply(client::TransportErrorKind::Timeout, "no reply (simulated)");

// The coils (Y10-Y1F, Y30-Y3F) a write sets, and to what: FC05, FC0F, and
// the control words D90C1/D90C2 (FC10).
std::vector<std::pair<uint16_t, bool>> coils_set_by(const modbus::Request& r) {
  std::vector<std::pair<uint16_t, bool>> out;
  if (const auto* c = std::get_if<modbus::WriteCoilRequest>(&r)) {
    out.emplace_back(c->coil, c->on());
  } else if (const auto* cs = std::get_if<modbus::WriteCoilsRequest>(&r)) {
    for (uint16_t i = 0; i < cs->count; ++i)
      out.emplace_back(static_cast<uint16_t>(cs->start + i), cs->bit(i));
  } else if (const auto* w = std::get_if<modbus::WriteRegistersRequest>(&r)) {
    const auto v = w->values();
    for (std::size_t k = 0; k < v.size(); ++k) {
      const uint16_t reg = static_cast<uint16_t>(w->start + k);
      if (reg != lec::kControlWordY10 && reg != lec::kControlWordY30) continue;
      const uint16_t base = reg == lec::kControlWordY10 ? 0x10 : 0x30;
      for (uint16_t b = 0; b < 16; ++b)
        out.emplace_back(static_cast<uint16_t>(base + b), ((v[k] >> b) & 1) != 0);
    }
  }
  return out;
}

}  // namespace

SimRun World::run() {
  const TimePoint end = clock_ + kRun;
  while (clock_ < end) {
    if (shutdown_at_ && clock_ >= *shutdown_at_ && !shutting_down_) begin_shutdown();
    act();
    // What next() answered without the wire (reads from the cache, when
    // their turn came) is answered before the exchange: it left first.
    const auto d = s_->next(clock_);
    deliver();
    if (d) {
      exchange(*d);
      deliver();
      continue;
    }
    TimePoint next = end;
    for (const Actor& a : actors_) next = std::min(next, a.next);
    if (auto w = s_->wake_at()) next = std::min(next, std::max(*w, clock_ + 1ms));
    if (shutdown_at_ && !shutting_down_) next = std::min(next, std::max(*shutdown_at_, clock_));
    clock_ = std::max(next, clock_ + 100us);
    check_holds();
  }
  // Drain: stops go out for up to 5 s, then the line closes.
  if (!shutting_down_) begin_shutdown();
  const TimePoint drain_end = clock_ + 5s;
  while (!s_->drained() && clock_ < drain_end) {
    const auto d = s_->next(clock_);
    deliver();
    if (d) {
      exchange(*d);
      deliver();
    } else {
      clock_ = std::max(clock_ + 1ms, s_->wake_at().value_or(clock_ + 1ms));
    }
  }
  closed_ = true;
  s_->shut_down(clock_);
  deliver();
  final_checks();
  return std::move(run_);
}

// As the Modbus TCP listener does (modbus_tcp_server.cpp): the gateway
// rule decides; a master that hangs up cancels what it had queued.
void World::submit_tcp(uint8_t id, modbus::Request request, const Via& via) {
  const auto pdu = modbus::encode_request_pdu(request);
  policy_.cache_max_age = via.cache_age;  // its listener's
  const auto decision = decide(policy_, id, *pdu);
  const auto* line = std::get_if<LineRequest>(&decision);
  if (!line) return;
  Job job;
  job.priority = line->priority;
  job.source = via.source;
  job.frame = line->frame;
  job.max_cache_age = line->max_cache_age;
  if (via.connection) job.not_before = via.connection->seen[id];
  job.attempts = line->attempts;
  const bool stop = job.priority == Priority::Emergency;
  const auto* coil = std::get_if<modbus::WriteCoilRequest>(&request);
  const std::size_t key = next_key_++;
  Tracked t;
  t.submitted = clock_;
  t.id = id;
  t.stop = stop;
  t.hold_on = coil && coil->coil == lec::address(Coil::HOLD) && coil->on();
  t.write = modbus::is_write(request);
  t.from = via.bounded;
  t.hard = client::stops_hard(request);
  t.starts = client::starts_motion(request);
  t.by_operator = via.by_operator;
  t.jog = via.jog;
  if (t.write) t.request = request;
  t.source = via.source;
  t.connection = via.connection;
  t.max_cache_age = job.max_cache_age;
  t.not_before = job.not_before;
  if (t.from) ++t.from->outstanding;
  // Ahead of it in its controller's lane: every write queued before it to
  // its controller, moved there in order, but for the starts a hard stop
  // refuses (scheduler.cpp). They leave the commands' turns.
  if (stop) {
    for (const std::size_t k : writes_waiting_[id]) {
      const Tracked& x = tracked_[k];
      turns_.left(k);
      if (!(t.hard && x.starts && !x.stop)) ++t.same_queued;
    }
    t.bound = stop_bound(t);
    ++run_.stops;
  }
  if (t.write) writes_waiting_[id].insert(key);
  tracked_.emplace(key, std::move(t));
  job.done = [this, key](const JobResult& r) { answered(key, r); };
  ++run_.jobs;
  const std::size_t known = s_->command_sources();
  const std::size_t depth = s_->queue_depth()[index(Priority::Command)];
  const JobId jid = s_->submit(std::move(job), clock_);
  if (key_of_.size() <= jid) key_of_.resize(jid + 1);
  key_of_[jid] = key;
  // Queued, not answered at once (the cache, a refusal): its turn will come.
  if (!stop && s_->queue_depth()[index(Priority::Command)] > depth) {
    turns_.queued(key, via.source, id);
    check_turns_memory(key, known, depth);
  }
  note(1, key, [&] {
    return fmt::format("submit #{} job {} to ID {}{}", key, jid, id, stop ? " STOP" : "");
  });
  if (via.hangs_up && chance(0.5)) {
    const bool cancelled = s_->cancel(jid, clock_);
    if (cancelled && stop)
      violation(fmt::format("stop #{} to ID {} was cancelled by a hang-up", key, id));
    note(2, key * 2 + cancelled, [&] {
      return fmt::format("hang-up #{}: {}", key, cancelled ? "cancelled" : "not cancelled");
    });
  }
  deliver();
}

void World::answered(std::size_t key, const JobResult& r) {
  Tracked& t = tracked_[key];
  if (++t.answers > 1) violation(fmt::format("job #{} answered twice", key));
  turns_.left(key);
  if (r.from_cache) from_cache(key, t, r);
  if (t.connection && r.failure == Failure::None)
    t.connection->seen[t.id] = std::max(t.connection->seen[t.id], r.started);

  if (t.write) writes_waiting_[t.id].erase(key);
  if (t.from && t.from->outstanding > 0) --t.from->outstanding;
  note(3, key * 16 + static_cast<uint64_t>(r.failure) * 2 + r.from_cache, [&] {
    return fmt::format("answer #{}: {}{}", key, failure_name(r.failure),
                       r.from_cache ? " (the cache)" : "");
  });
  if (t.write && r.failure == Failure::None) devices_[t.id].last_write_key = key;
  // Invariant 7's record: what each write answered done set, in the order
  // of the answers (the wire's).
  if (t.write && r.failure == Failure::None && r.reply && t.request &&
      !std::holds_alternative<modbus::ExceptionResponse>(r.reply->pdu)) {
    for (const auto& [coil, on] : coils_set_by(*t.request)) devices_[t.id].coils[coil] = {on, key};
  }
  if (t.stop) {
    if (r.failure == Failure::Cancelled)
      violation(fmt::format("stop #{} to ID {} cancelled", key, t.id));
    if (r.failure == Failure::ShuttingDown && !closed_)
      violation(fmt::format("stop #{} to ID {} refused by the shutdown before the line closed", key,
                            t.id));
    const Device& d = devices_[t.id];
    if (d.kind == Kind::Clean && r.failure == Failure::None) {
      const Duration wait = r.started - t.submitted;
      run_.stop_wait_ms.push_back(ms(wait));
      if (t.by_operator && t.hard) run_.operator_stop_wait_ms.push_back(ms(wait));
      const Duration bound = t.bound;
      if (wait > bound)
        violation(
            fmt::format("stop #{} to answering ID {} waited {:.1f} ms for the wire (bound "
                        "{:.1f} ms)",
                        key, t.id, ms(wait), ms(bound)));
      if (t.hold_on) holds_.push_back({t.id, clock_, key});
    }
  }
}

void World::exchange(const Dispatch& d) {
  ++run_.exchanges;

  // After a lost exchange the line's RtuMaster keeps the line quiet for a
  // reply window (late replies), except for a stop or release to another ID.
  if (!client::stops_or_releases(d.frame.pdu) || d.frame.id == lost_id_)
    clock_ = std::max(clock_, quiet_at_);
  if (const std::size_t key = key_of(d.id)) {
    const Tracked& t = tracked_[key];
    // Invariant 6: a start queued before a hard stop to its controller
    // never reaches the wire after that stop.
    if (t.starts && !t.stop && on_wire_hard_[t.id] > key)
      violation(fmt::format("start #{} to ID {} went to the wire after stop #{}, accepted after it",
                            key, t.id, on_wire_hard_[t.id]));
    if (t.hard) on_wire_hard_[t.id] = std::max(on_wire_hard_[t.id], key);
    // Invariant 4: clients' commands take turns by source (turns_check.hpp).
    if (const std::string broken = turns_.on_wire(key); !broken.empty()) violation(broken);
    if (t.jog) jog_sources_.insert(t.source);
  }
  Device& dev = devices_[d.frame.id];
  const TimePoint start = clock_;
  const bool flap_dead =
      dev.kind == Kind::Flapping && clock_ >= dev.dead_from && clock_ < dev.dead_until;
  const bool lost =
      dev.kind == Kind::Dead || flap_dead || (dev.kind == Kind::Noisy && chance(dev.fail));
  note(4, d.id * 2 + lost, [&] {
    return fmt::format("wire job {} to ID {} {}", d.id, d.frame.id, lost ? "lost" : "answered");
  });
  if (lost) {
    clock_ += timing_.wire_time(12) + kTimeout;
    quiet_at_ = clock_ + kTimeout;
    lost_id_ = d.frame.id;
    if (dev.twin && dev.kind == Kind::Noisy)
      dev.twin->handle(d.frame.pdu, start);  // heard, reply lost
    if (const std::size_t key = key_of(d.id)) turns_.lost(key);
    s_->failed(kNoReply, start, clock_);
    return;
  }
  auto reply = dev.twin->handle(d.frame.pdu, start);
  clock_ += exchange_time(d.frame.pdu, d.frame.id);
  s_->completed({d.frame.id, std::move(reply)}, start, clock_);
}

void World::deliver() {
  for (auto& c : s_->take_completions()) c.done(c.result);
  s_->take_events();
}

void World::begin_shutdown() {
  shutting_down_ = true;
  note(5, 0, [] { return std::string("shutdown begins"); });
  s_->begin_shutdown(clock_);
  deliver();
}

}  // namespace detail

SimRun run_line_sim(uint64_t seed, bool trace) {
  return detail::World(seed, trace).run();
}

}  // namespace lec6::serve::sim_testing
