// The line simulation (line_sim.hpp): a plant drawn from a seed, run on a
// virtual clock through the real scheduler and gateway rule, the twin's
// controllers answering. One loop, one random generator: a seed replays.

#include "serve/sim/line_sim.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <random>

#include "lec6/client/interrupt.hpp"
#include "lec6/lec/flags.hpp"
#include "lec6/lec/memory_map.hpp"
#include "lec6/sim/controller.hpp"
#include "line/scheduler.hpp"
#include "modbus_tcp/gateway.hpp"

namespace lec6::serve::sim_testing {
namespace {

using namespace std::chrono_literals;
using lec::Coil;

constexpr Duration kRun = 3s;
constexpr Duration kTimeout = 65ms;     // a reply window that stays empty
constexpr std::size_t kMaxQueued = 32;  // per connection (ModbusTcpLimits::max_queued)
const client::TransportError kNoReply(client::TransportErrorKind::Timeout, "no reply (simulated)");

enum class Kind { Clean, Dead, Noisy, Flapping };

struct Device {
  uint8_t id = 1;
  Kind kind = Kind::Clean;
  double fail = 0;                        // Noisy: the chance an exchange fails
  TimePoint dead_from{}, dead_until{};    // Flapping: a dead spell
  std::unique_ptr<sim::Controller> twin;  // not for Dead
  bool driven_by_plc = false;
  std::size_t last_write_key = 0;  // the last write answered done
  // Per coil, what the last write answered done set it to, and that write's key.
  std::map<uint16_t, std::pair<bool, std::size_t>> coils;
};

struct Actor;

struct Tracked {
  TimePoint submitted{};
  uint8_t id = 0;
  bool stop = false;
  bool hold_on = false;
  bool write = false;
  int answers = 0;
  std::size_t same_queued = 0;  // stops to the same controller already queued
  std::optional<JobResult> result;
  Actor* from = nullptr;  // a PLC connection, bounded like lec serve's
  Duration bound{};       // for a stop: the lane's bound, as the line stood at its submit
  bool hard = false;      // a hard stop (client::stops_hard)
  bool starts = false;    // a write that may start motion (client::starts_motion)
  bool in_lane = false;   // in the emergency lane: a stop, or a write a release moved there
  bool by_operator = false;
  bool resending = false;                  // its last exchange was lost; a resend may follow
  std::optional<modbus::Request> request;  // a write's (invariant 7)
  Priority priority = Priority::Command;
  JobSource source = 0;            // its connection (invariant 4: commands take turns by it)
  std::size_t submit_command = 0;  // client commands on the wire before its submit
};

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

struct Actor {
  enum class Type { Plc, Scada, Operator, Jogger } type;
  Duration period{};
  TimePoint next{};
  std::vector<uint8_t> ids;
  int encoding = 0;  // Plc: 0 FC05, 1 FC0F, 2 FC10 word
  bool hangs_up = false;
  std::size_t depth = 0;        // Scada: reads kept queued
  std::size_t outstanding = 0;  // Plc: as lec serve's Modbus TCP session, at most kMaxQueued
  JobSource source = 0;         // its connection: client commands take turns by it
};

class World {
 public:
  explicit World(uint64_t seed, bool trace) : rng_(seed), trace_on_(trace) {
    run_.seed = seed;
    draw_plant();
  }

  SimRun run() {
    const TimePoint end = clock_ + kRun;
    while (clock_ < end) {
      if (shutdown_at_ && clock_ >= *shutdown_at_ && !shutting_down_) begin_shutdown();
      act();
      if (auto d = s_->next(clock_)) {
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
      if (auto d = s_->next(clock_)) {
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

 private:
  bool chance(double p) { return std::uniform_real_distribution<double>(0, 1)(rng_) < p; }
  int pick(int lo, int hi) { return std::uniform_int_distribution<int>(lo, hi)(rng_); }

  // An event: hashed by its numbers (cheap), written out only when tracing.
  template <typename Text>
  void note(uint64_t a, uint64_t b, Text&& text) {
    for (uint64_t v : {a, b, static_cast<uint64_t>(clock_.time_since_epoch().count())})
      run_.hash = (run_.hash ^ v) * 1099511628211ULL;
    if (trace_on_) run_.trace += fmt::format("{:10.3f} {}\n", ms(clock_ - start_), text());
  }
  static double ms(Duration d) { return to_seconds(d) * 1000; }

  void draw_plant() {
    const int n = pick(1, 8);
    timing_.baud = chance(0.5) ? 38400 : 115200;
    SchedulerConfig config;
    config.timing = timing_;
    config.offline_after = 3;
    config.probe_interval = std::chrono::milliseconds(pick(200, 2000));
    std::string words = fmt::format("{} controllers at {} baud:", n, timing_.baud);
    for (int i = 1; i <= n; ++i) {
      Device d;
      d.id = static_cast<uint8_t>(i);
      const double r = std::uniform_real_distribution<double>(0, 1)(rng_);
      d.kind = r < 0.55   ? Kind::Clean
               : r < 0.7  ? Kind::Dead
               : r < 0.85 ? Kind::Noisy
                          : Kind::Flapping;
      if (i == 1) d.kind = Kind::Clean;  // the operator's axis answers
      if (d.kind == Kind::Noisy) d.fail = std::uniform_real_distribution<double>(0.05, 0.5)(rng_);
      if (d.kind == Kind::Flapping) {
        d.dead_from = clock_ + std::chrono::milliseconds(pick(0, 2000));
        d.dead_until = d.dead_from + std::chrono::milliseconds(pick(300, 3000));
      }
      if (d.kind != Kind::Dead) {
        d.twin = std::make_unique<sim::Controller>(sim::ActuatorConfig{}, clock_);
        const auto on = [&](Coil c) {
          d.twin->handle(modbus::WriteCoilRequest{lec::address(c), modbus::kCoilOn}, clock_);
        };
        on(Coil::SerialMode);
        on(Coil::SVON);
      }
      config.axes.push_back(
          {d.id, chance(0.7) ? std::chrono::milliseconds(pick(50, 200)) : Duration{}});
      words += fmt::format(" {}={}", i,
                           d.kind == Kind::Clean   ? "clean"
                           : d.kind == Kind::Dead  ? "dead"
                           : d.kind == Kind::Noisy ? fmt::format("noisy({:.2f})", d.fail)
                                                   : "flapping");
      devices_[d.id] = std::move(d);
    }
    clock_ += 1s;  // the servos turn on
    start_ = clock_;
    s_ = std::make_unique<Scheduler>(config, clock_);
    policy_.units.clear();
    for (const auto& [id, d] : devices_) policy_.units.insert(id);
    const auto some_ids = [&] {
      std::vector<uint8_t> ids;
      for (const auto& [id, d] : devices_)
        if (chance(0.5)) ids.push_back(id);
      if (ids.empty()) ids.push_back(static_cast<uint8_t>(pick(1, n)));
      return ids;
    };
    for (int i = pick(0, 2); i > 0; --i) {
      Actor a{Actor::Type::Plc,
              std::chrono::milliseconds(pick(10, 100)),
              clock_,
              some_ids(),
              pick(0, 2),
              chance(0.3),
              0};
      for (uint8_t id : a.ids) devices_[id].driven_by_plc = true;
      words += fmt::format("; PLC every {} ms (FC{}) to {} IDs", ms(a.period),
                           a.encoding == 0   ? "05"
                           : a.encoding == 1 ? "0F"
                                             : "10 D90C1",
                           a.ids.size());
      actors_.push_back(a);
    }
    for (int i = pick(0, 3); i > 0; --i) {
      actors_.push_back({Actor::Type::Scada, 20ms, clock_, some_ids(), 0, chance(0.3),
                         static_cast<std::size_t>(pick(3, 20))});
      words += "; SCADA flood";
    }
    actors_.push_back({Actor::Type::Operator,
                       std::chrono::milliseconds(pick(100, 700)),
                       clock_ + 200ms,
                       {},
                       0,
                       chance(0.3),
                       0});
    actors_.push_back({Actor::Type::Jogger, 400ms, clock_, {}, 0, false, 0});
    // Each its own connection (the jogger's writes: the daemon's own source, 0).
    for (std::size_t i = 0; i + 1 < actors_.size(); ++i) actors_[i].source = i + 1;
    if (chance(0.2)) {
      shutdown_at_ = clock_ + std::chrono::milliseconds(pick(300, 2700));
      words += "; shutdown";
    }
    run_.plant = words;
    note(0, 0, [&] { return words; });
  }

  // ---- actors --------------------------------------------------------------

  void act() {
    for (Actor& a : actors_) {
      while (a.next <= clock_) {
        a.next += a.period;
        switch (a.type) {
          case Actor::Type::Plc:
            for (uint8_t id : a.ids)
              if (a.outstanding < kMaxQueued) plc_image(a, id);
            break;
          case Actor::Type::Scada:
            // Keeps `depth` reads queued (refused or cached ones come back at once).
            for (std::size_t n = 0;
                 n < a.depth && s_->queue_depth()[index(Priority::Command)] < a.depth; ++n) {
              const uint8_t id = a.ids[static_cast<std::size_t>(pick(0, int(a.ids.size()) - 1))];
              submit_tcp(id, modbus::ReadRegistersRequest{lec::kStateData, 7}, a.hangs_up, nullptr,
                         false, a.source);
            }
            break;
          case Actor::Type::Operator:
            operator_stop(a);
            a.period = std::chrono::milliseconds(pick(100, 700));
            break;
          case Actor::Type::Jogger:
            jog();
            break;
        }
      }
    }
  }

  void plc_image(Actor& a, uint8_t id) {
    // An output image: running (servo on, maybe DRIVE), or a stop in it.
    const int what = pick(0, 9);
    bool hold = what == 7, svon = what != 8, reset = what == 9;
    std::array<bool, 16> y{};  // Y10-Y1F
    y[0x18 - 0x10] = hold;
    y[0x19 - 0x10] = svon;
    y[0x1B - 0x10] = reset;
    modbus::Request r;
    if (a.encoding == 0) {
      const Coil c = hold ? Coil::HOLD : reset ? Coil::RESET : Coil::SVON;
      const bool on = c == Coil::SVON ? svon : true;
      r = modbus::WriteCoilRequest{lec::address(c), on ? modbus::kCoilOn : modbus::kCoilOff};
    } else if (a.encoding == 1) {
      r = modbus::WriteCoilsRequest::of(0x18, std::span<const bool>(&y[8], 7));
    } else {
      uint16_t word = 0;
      for (int b = 0; b < 16; ++b) word |= static_cast<uint16_t>(y[b]) << b;
      const uint16_t words[] = {word};
      r = modbus::WriteRegistersRequest::of(lec::kControlWordY10, words);
    }
    submit_tcp(id, std::move(r), a.hangs_up, &a, false, a.source);
  }

  void operator_stop(const Actor& a) {
    const uint8_t id = static_cast<uint8_t>(pick(1, static_cast<int>(devices_.size())));
    if (chance(0.5)) {
      submit_tcp(id, modbus::WriteCoilRequest{lec::address(Coil::RESET), modbus::kCoilOn},
                 a.hangs_up, nullptr, true, a.source);
      submit_tcp(id, modbus::WriteCoilRequest{lec::address(Coil::RESET), modbus::kCoilOff},
                 a.hangs_up, nullptr, true, a.source);
    } else {
      submit_tcp(id, modbus::WriteCoilRequest{lec::address(Coil::HOLD), modbus::kCoilOn},
                 a.hangs_up, nullptr, true, a.source);
    }
  }

  // An operator's jog on a controller no PLC drives: HOLD off, JOG+ on for a while, off.
  void jog() {
    for (auto& [id, d] : devices_) {
      if (d.kind != Kind::Clean || d.driven_by_plc || !chance(0.3)) continue;
      const bool on = chance(0.6);
      if (on)
        submit_tcp(id, modbus::WriteCoilRequest{lec::address(Coil::HOLD), modbus::kCoilOff}, false);
      submit_tcp(id,
                 modbus::WriteCoilRequest{lec::address(Coil::JOG_PLUS),
                                          on ? modbus::kCoilOn : modbus::kCoilOff},
                 false);
    }
  }

  // As the Modbus TCP listener does (modbus_tcp_server.cpp): the gateway
  // rule decides; a master that hangs up cancels what it had queued.
  void submit_tcp(uint8_t id, modbus::Request request, bool hangs_up, Actor* from = nullptr,
                  bool by_operator = false, JobSource source = 0) {
    const auto pdu = modbus::encode_request_pdu(request);
    const auto decision = decide(policy_, id, *pdu);
    const auto* line = std::get_if<LineRequest>(&decision);
    if (!line) return;
    Job job;
    job.priority = line->priority;
    job.source = source;
    job.frame = line->frame;
    job.max_cache_age = line->max_cache_age;
    job.attempts = line->attempts;
    const bool stop = job.priority == Priority::Emergency;
    const auto* coil = std::get_if<modbus::WriteCoilRequest>(&request);
    const bool hold_on = coil && coil->coil == lec::address(Coil::HOLD) && coil->on();
    const std::size_t key = next_key_++;
    Tracked t{clock_,
              id,
              stop,
              hold_on,
              modbus::is_write(request),
              0,
              0,
              std::nullopt,
              from,
              {},
              false,
              false,
              false,
              false,
              false,
              std::nullopt,
              Priority::Command};
    t.hard = client::stops_hard(request);
    t.starts = client::starts_motion(request);
    t.in_lane = stop;
    t.by_operator = by_operator;
    if (t.write) t.request = request;
    t.priority = job.priority;
    t.source = source;
    t.submit_command = commands_sent_;
    if (from) ++from->outstanding;
    // Ahead of it in its controller's lane: every write queued before it to
    // its controller, moved there in order, but for the starts a hard stop
    // refuses (scheduler.cpp).
    if (stop) {
      for (auto& [k, x] : tracked_) {
        if (x.id != id || !x.write || x.answers > 0) continue;
        x.in_lane = true;
        if (!(t.hard && x.starts && !x.stop)) ++t.same_queued;
      }
      t.bound = stop_bound(t);
      if (t.hard) last_hard_stop_[id] = key;
    }
    if (modbus::is_write(request)) ++pending_writes_[id];
    tracked_[key] = t;
    job.done = [this, key](const JobResult& r) { answered(key, r); };
    if (stop) ++queued_stops_[id], ++run_.stops;
    ++run_.jobs;
    const JobId jid = s_->submit(std::move(job), clock_);
    key_of_[jid] = key;
    note(1, key, [&] {
      return fmt::format("submit #{} job {} to ID {}{}", key, jid, id, stop ? " STOP" : "");
    });
    if (hangs_up && chance(0.5)) {
      const bool cancelled = s_->cancel(jid, clock_);
      if (cancelled && stop)
        violation(fmt::format("stop #{} to ID {} was cancelled by a hang-up", key, id));
      note(2, key * 2 + cancelled, [&] {
        return fmt::format("hang-up #{}: {}", key, cancelled ? "cancelled" : "not cancelled");
      });
    }
    deliver();
  }

  void answered(std::size_t key, const JobResult& r) {
    Tracked& t = tracked_[key];
    if (++t.answers > 1) violation(fmt::format("job #{} answered twice", key));
    t.result = r;

    if (t.stop && queued_stops_[t.id] > 0) --queued_stops_[t.id];
    if (t.write && pending_writes_[t.id] > 0) --pending_writes_[t.id];
    if (t.from && t.from->outstanding > 0) --t.from->outstanding;
    note(3, key * 8 + static_cast<uint64_t>(r.failure),
         [&] { return fmt::format("answer #{}: {}", key, failure_name(r.failure)); });
    if (t.write && r.failure == Failure::None) devices_[t.id].last_write_key = key;
    // Invariant 7's record: what each write answered done set, in the order
    // of the answers (the wire's).
    if (t.write && r.failure == Failure::None && r.reply && t.request &&
        !std::holds_alternative<modbus::ExceptionResponse>(r.reply->pdu)) {
      for (const auto& [coil, on] : coils_set_by(*t.request))
        devices_[t.id].coils[coil] = {on, key};
    }
    if (t.stop) {
      if (r.failure == Failure::Cancelled)
        violation(fmt::format("stop #{} to ID {} cancelled", key, t.id));
      if (r.failure == Failure::ShuttingDown && !closed_)
        violation(fmt::format("stop #{} to ID {} refused by the shutdown before the line closed",
                              key, t.id));
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

  // Emergency lane bound (emergency_lane.hpp): the exchange on the wire,
  // then per round one exchange for each other controller with a stop: an
  // answered one for a clean controller; a lost one for a noisy or flapping
  // one (it counts as answering until an exchange fails: nobody can know
  // before); and one lost exchange for all the dead ones together (they
  // wait their backoff behind the answering ones). One round per stop to
  // the same controller queued ahead of it.
  Duration stop_bound(const Tracked& t) const {
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

  Duration exchange_time(const modbus::Request& r, uint8_t id) const {
    const auto q = modbus::encode_request({id, r});
    return timing_.transaction_limit(q ? q->size() : 8, modbus::expected_response_length(r));
  }

  // ---- the wire ------------------------------------------------------------

  void exchange(const Dispatch& d) {
    ++run_.exchanges;

    // After a lost exchange the line's RtuMaster keeps the line quiet for a
    // reply window (late replies), except for a stop or release to another ID.
    if (!client::stops_or_releases(d.frame.pdu) || d.frame.id == lost_id_)
      clock_ = std::max(clock_, quiet_at_);
    if (const auto k = key_of_.find(d.id); k != key_of_.end()) {
      Tracked& t = tracked_[k->second];
      const bool again = t.resending;  // a further attempt: not a turn of its own
      t.resending = false;
      // Invariant 6: a start queued before a hard stop to its controller
      // never reaches the wire after that stop.
      if (t.starts && !t.stop && on_wire_hard_[t.id] > k->second)
        violation(
            fmt::format("start #{} to ID {} went to the wire after stop #{}, accepted after it",
                        k->second, t.id, on_wire_hard_[t.id]));
      if (t.hard) on_wire_hard_[t.id] = std::max(on_wire_hard_[t.id], k->second);
      // Invariant 4: clients' commands take turns by connection
      // (line/command_turns.hpp; the polls' turns between): no command waits
      // without bound. A connection's commands go in the order they came,
      // and while one waits, no other connection goes twice; only one that
      // waits out its controller's backoff for a resend may be passed over.
      if (t.priority == Priority::Command && !t.in_lane && !again) {
        const std::size_t previous = last_command_of_.contains(t.source)
                                         ? last_command_of_[t.source]
                                         : std::numeric_limits<std::size_t>::max();
        for (const auto& [key, x] : tracked_) {
          if (key >= k->second && x.source == t.source) continue;
          if (x.answers > 0 || x.in_lane || x.priority != Priority::Command || x.resending ||
              key == k->second)
            continue;
          if (x.source == t.source) {
            violation(
                fmt::format("command #{} to ID {} went to the wire before command #{} to "
                            "ID {} of its connection, queued before it",
                            k->second, t.id, key, x.id));
            break;
          }
          // x has waited since its submit and since its connection's last turn.
          const std::size_t since =
              std::max(x.submit_command,
                       last_command_of_.contains(x.source) ? last_command_of_[x.source] + 1 : 0);
          if (previous != std::numeric_limits<std::size_t>::max() && previous >= since) {
            violation(
                fmt::format("command #{} to ID {}: its connection's second turn while "
                            "command #{} to ID {} of another one waited",
                            k->second, t.id, key, x.id));
            break;
          }
        }
        last_command_of_[t.source] = commands_sent_++;
      }
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
      if (const auto k = key_of_.find(d.id); k != key_of_.end())
        tracked_[k->second].resending = true;
      s_->failed(kNoReply, start, clock_);
      return;
    }
    auto reply = dev.twin->handle(d.frame.pdu, start);
    clock_ += exchange_time(d.frame.pdu, d.frame.id);
    s_->completed({d.frame.id, std::move(reply)}, start, clock_);
  }

  void deliver() {
    for (auto& c : s_->take_completions()) c.done(c.result);
    s_->take_events();
  }

  void begin_shutdown() {
    shutting_down_ = true;
    note(5, 0, [] { return std::string("shutdown begins"); });
    s_->begin_shutdown(clock_);
    deliver();
  }

  // Invariant 5: a HOLD answered done holds a clean axis: at rest after its
  // deceleration (jog 50 mm/s at 1000 mm/s2: 50 ms) plus one transaction,
  // unless another write to that controller came after it.
  void check_holds() {
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
  void check_coils() {
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

  void final_checks() {
    check_coils();
    for (const auto& [key, t] : tracked_) {
      if (t.answers == 0) violation(fmt::format("job #{} to ID {} never answered", key, t.id));
    }
  }

  void violation(const std::string& what) {
    note(6, run_.violations.size(), [&] { return "VIOLATION " + what; });
    run_.violations.push_back(what);
  }

  std::mt19937_64 rng_;
  bool trace_on_;
  SimRun run_;
  TimePoint clock_ = TimePoint{} + 1s;
  TimePoint start_{};
  modbus::LineTiming timing_;
  std::map<uint8_t, Device> devices_;
  std::vector<Actor> actors_;
  std::unique_ptr<Scheduler> s_;
  GatewayPolicy policy_;
  std::map<std::size_t, Tracked> tracked_;
  std::size_t commands_sent_ = 0;                     // client commands on the wire
  std::map<JobSource, std::size_t> last_command_of_;  // each connection's last, by that count
  std::map<uint8_t, std::size_t> queued_stops_;
  std::map<uint8_t, std::size_t> pending_writes_;
  struct Hold {
    uint8_t id;
    TimePoint at;
    std::size_t key;
  };
  std::vector<Hold> holds_;
  std::size_t next_key_ = 1;
  TimePoint quiet_at_{};                           // the end of the quiet after a lost exchange
  uint8_t lost_id_ = 0;                            // the ID of the last lost exchange
  std::map<JobId, std::size_t> key_of_;            // the scheduler's job id -> our key
  std::map<uint8_t, std::size_t> last_hard_stop_;  // per ID, the last hard stop's key
  std::map<uint8_t, std::size_t> on_wire_hard_;    // per ID, the latest hard stop on the wire
  std::optional<TimePoint> shutdown_at_;
  bool shutting_down_ = false;
  bool closed_ = false;
};

}  // namespace

SimRun run_line_sim(uint64_t seed, bool trace) {
  return World(seed, trace).run();
}

}  // namespace lec6::serve::sim_testing
