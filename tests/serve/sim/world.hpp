#pragma once
// The line simulation's world (line_sim.hpp): the plant a seed draws, its
// actors, the line they share, and what the invariants keep track of.
//   line_sim.cpp    the loop on the virtual clock, the gateway, the wire
//   plant.cpp       the plant and its actors (PLCs, SCADA, HMI, operators)
//   invariants.cpp  the checks (but invariant 4's: turns_check.hpp)
// One random generator: a seed replays.

#include <fmt/format.h>

#include <map>
#include <memory>
#include <optional>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "lec6/lec/flags.hpp"
#include "lec6/sim/controller.hpp"
#include "line/scheduler.hpp"
#include "modbus_tcp/gateway.hpp"
#include "serve/sim/line_sim.hpp"
#include "serve/sim/turns_check.hpp"

namespace lec6::serve::sim_testing::detail {

using namespace std::chrono_literals;
using lec::Coil;

constexpr Duration kRun = 3s;
constexpr Duration kTimeout = 65ms;     // a reply window that stays empty
constexpr std::size_t kMaxQueued = 32;  // per connection (ModbusTcpLimits::max_queued)
// The scheduler forgets idle sources when it knows this many more than it
// has commands queued (Scheduler::submit): its memory of turns stays within it.
constexpr std::size_t kSourcesBeyondQueue = 64;

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
  Actor* from = nullptr;        // counts its requests outstanding (a PLC's connection; the HMI)
  Duration bound{};             // for a stop: the lane's bound, as the line stood at its submit
  bool hard = false;            // a hard stop (client::stops_hard)
  bool starts = false;          // a write that may start motion (client::starts_motion)
  bool by_operator = false;
  bool jog = false;                        // an operator's jog (an operation: its own source)
  std::optional<modbus::Request> request;  // a write's (invariant 7)
  JobSource source = 0;  // its connection or operation (the jogs reached: SimRun::jog_sources)
  Actor* connection = nullptr;  // one that keeps what it saw of each ID (Job::not_before)
  Duration max_cache_age{};     // a read's (invariant 8)
  TimePoint not_before{};
};

struct Actor {
  // Hmi: a panel or web page that opens a connection per read (a new source
  // each), a few at a time.
  enum class Type { Plc, Scada, Operator, Jogger, Hmi } type;
  Duration period{};
  TimePoint next{};
  std::vector<uint8_t> ids;
  int encoding = 0;  // Plc: 0 FC05, 1 FC0F, 2 FC10 word
  bool hangs_up = false;
  std::size_t depth = 0;        // Scada: reads kept queued; Hmi: reads at a time
  std::size_t outstanding = 0;  // Plc: as lec serve's Modbus TCP session, at most kMaxQueued
  JobSource source = 0;         // its connection: client commands take turns by it
  Duration cache_age{};         // Scada, Hmi: its listener's cache_max_age (0: none)
  std::map<uint8_t, TimePoint> seen{};  // Scada: what it last saw of each ID (Job::not_before)
};

// Who sends a request through the gateway, and how (submit_tcp).
struct Via {
  JobSource source = 0;
  bool hangs_up = false;
  Actor* bounded = nullptr;     // counts its outstanding requests (Actor::outstanding)
  Actor* connection = nullptr;  // keeps what it saw (Actor::seen)
  Duration cache_age{};         // for reads
  bool by_operator = false;
  bool jog = false;
};

class World {
 public:
  explicit World(uint64_t seed, bool trace) : rng_(seed), trace_on_(trace) {
    run_.seed = seed;
    draw_plant();
  }

  SimRun run();

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

  // ---- the plant and its actors (plant.cpp) --------------------------------

  void draw_plant();

  void act();

  uint8_t any_of(const std::vector<uint8_t>& ids);

  void plc_image(Actor& a, uint8_t id);

  void operator_stop(const Actor& a);

  // An operator's jog on a controller no PLC drives: HOLD off, JOG+ on for a
  // while, off. Each an operation of its own (HTTP): a source of its own.
  void jog();

  // ---- the line (line_sim.cpp) ---------------------------------------------

  // As the Modbus TCP listener does (modbus_tcp_server.cpp): the gateway
  // rule decides; a master that hangs up cancels what it had queued.
  void submit_tcp(uint8_t id, modbus::Request request, const Via& via);

  void answered(std::size_t key, const JobResult& r);

  void exchange(const Dispatch& d);

  void deliver();

  void begin_shutdown();

  // ---- the invariants (invariants.cpp) -------------------------------------

  // Invariant 9: the scheduler's memory of turns stays bounded however many
  // sources come and go (a connection per request): once a command is
  // queued, it knows at most kSourcesBeyondQueue sources more than it has
  // commands queued. Counts the submits at which it forgot idle ones.
  void check_turns_memory(std::size_t key, std::size_t known_before, std::size_t depth_before);

  // Invariant 8: a read answered from the cache is no older than its
  // max_cache_age allows, nor than what its connection saw (Job::not_before).
  // Counts those answered at submit and those answered when their turn came.
  void from_cache(std::size_t key, const Tracked& t, const JobResult& r);

  // Emergency lane bound (emergency_lane.hpp): the exchange on the wire,
  // then per round one exchange for each other controller with a stop: an
  // answered one for a clean controller; a lost one for a noisy or flapping
  // one (it counts as answering until an exchange fails: nobody can know
  // before); and one lost exchange for all the dead ones together (they
  // wait their backoff behind the answering ones). One round per stop to
  // the same controller queued ahead of it.
  Duration stop_bound(const Tracked& t) const;

  Duration exchange_time(const modbus::Request& r, uint8_t id) const;

  // Invariant 5: a HOLD answered done holds a clean axis: at rest after its
  // deceleration (jog 50 mm/s at 1000 mm/s2: 50 ms) plus one transaction,
  // unless another write to that controller came after it.
  void check_holds();

  // Invariant 7: no answer says success where the twin disagrees. Each coil
  // of a controller that hears only what it answers (clean or flapping; a
  // noisy one hears writes whose replies are lost) holds what the last write
  // answered done set it to.
  void check_coils();

  void final_checks();

  void violation(const std::string& what);

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
  TurnsCheck turns_;                 // invariant 4
  JobSource next_source_ = 1;        // for a connection or operation of its own
  std::set<JobSource> jog_sources_;  // the jogs' operations that reached the wire
  std::size_t cache_answers_ = 0;    // answers the clients got from the cache
  std::map<uint8_t, std::set<std::size_t>> writes_waiting_;  // per ID, the writes not answered
  struct Hold {
    uint8_t id;
    TimePoint at;
    std::size_t key;
  };
  std::vector<Hold> holds_;
  std::size_t next_key_ = 1;
  TimePoint quiet_at_{};             // the end of the quiet after a lost exchange
  uint8_t lost_id_ = 0;              // the ID of the last lost exchange
  std::vector<std::size_t> key_of_;  // the scheduler's job id -> our key (0: its own)
  std::size_t key_of(JobId id) const { return id < key_of_.size() ? key_of_[id] : 0; }
  std::map<uint8_t, std::size_t> on_wire_hard_;  // per ID, the latest hard stop on the wire
  std::optional<TimePoint> shutdown_at_;
  bool shutting_down_ = false;
  bool closed_ = false;
};

}  // namespace lec6::serve::sim_testing::detail
