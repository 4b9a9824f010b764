#pragma once
// Several simulated controllers on one RS485 line (digest §1–§2), sans-I/O.
//
// The bus is fed the bytes the master sent, each chunk stamped with the time
// its last byte arrived, and hands back the replies with the time their first
// byte must start leaving. It never reads a clock and never sleeps.
//
// Driving it from an event loop (real port or pty, SteadyClock):
//
//   for (;;) {
//     wait for input until bus.next_deadline() (forever when nullopt);
//     if bytes arrived: bus.receive(bytes, clock.now());
//     bus.advance(clock.now());
//     for (auto& r : bus.take_replies(clock.now())) write(r.bytes);
//   }
//
// Driving it from an in-process link on a VirtualClock (waiting costs nothing):
//
//   write(query):  clock.advance(line.wire_time(query.size()));   // the query's last byte is in
//                  bus.receive(query, clock.now());
//   read_some(buf, deadline):
//     for (;;) {
//       bus.advance(clock.now());
//       if (auto rs = bus.take_replies(clock.now()); !rs.empty()) {
//         clock.set(rs.front().end);  // the reply's last byte has arrived
//         return copy of rs.front().bytes (keep the rest for the next read);
//       }
//       auto d = bus.next_deadline();
//       if (!d || *d > deadline) { clock.set(max(now, deadline)); return 0; }
//       clock.set(max(now, *d));
//     }
//
// Thread safety: none inside; a Bus and its Controllers are used by one thread at a time (lec sim:
// its event loop's thread).

#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <random>
#include <set>
#include <span>
#include <vector>

#include "lec6/clock.hpp"
#include "lec6/modbus/framer.hpp"
#include "lec6/modbus/pdu.hpp"
#include "lec6/modbus/timing.hpp"
#include "lec6/sim/behaviour.hpp"
#include "lec6/sim/controller.hpp"

namespace lec6::sim {

// Faults applied to outgoing replies, each with its own probability per reply
// (0 = never, 1 = always), drawn from a generator seeded with `seed`, so a
// run is reproducible.
struct FaultConfig {
  double drop = 0.0;     // the reply is not sent at all
  double corrupt = 0.0;  // one byte of the reply is changed (the CRC then fails)
  double garbage = 0.0;  // 1–garbage_max_bytes random bytes are sent right before the reply
  unsigned garbage_max_bytes = 4;
  double delay = 0.0;  // the reply starts `extra_delay` later than it should
  Duration extra_delay = std::chrono::milliseconds(50);
  // Idle-line noise, bytes/s: random bytes at random times while nobody
  // transmits (exponential gaps of mean 1/rate between them, each byte one
  // character time on the wire, so the rate saturates at the line's
  // character rate). Every listener hears them: the controllers (a byte
  // within Ts of a query corrupts it) and the master (Reply::noise). Drawn
  // from its own generator (seeded from `seed`), so turning noise on does not
  // change which replies the other faults hit.
  double noise_rate = 0.0;
  // Two controllers set to one ID (each of these IDs is there twice): both
  // answer, and with probability `collision` per reply their replies collide
  // on the line: the master gets a reply whose header (ID, function, byte
  // count: the same in both) is intact but whose data and CRC are garbled.
  // Otherwise they happened to agree.
  std::vector<uint8_t> duplicate_ids{};
  double collision = 0.5;
  uint64_t seed = 1;
  bool any() const noexcept {
    return drop > 0 || corrupt > 0 || garbage > 0 || delay > 0 || noise_rate > 0 ||
           !duplicate_ids.empty();
  }
};

// One reply on the wire.
struct Reply {
  uint8_t id = 0;
  TimePoint start;  // the first byte starts leaving
  TimePoint end;    // the last byte has left: start + wire time of `bytes`
  modbus::Bytes bytes;
  bool noise = false;  // idle-line noise (id 0): for every master on the line
};

class Bus {
 public:
  struct Stats {
    uint64_t frames = 0;      // frames delimited on the line
    uint64_t replies = 0;     // replies scheduled (before faults)
    uint64_t broadcasts = 0;  // broadcast writes executed
    uint64_t bad_frames = 0;  // bad CRC, too short / long: silence
    uint64_t other_ids = 0;   // addressed to an ID not on this bus: silence
    uint64_t exceptions = 0;  // exception replies
    uint64_t faults_dropped = 0;
    uint64_t faults_corrupted = 0;
    uint64_t faults_garbage = 0;
    uint64_t faults_delayed = 0;
    uint64_t noise_bytes = 0;  // idle-line noise put on the line
    uint64_t long_frames = 0;  // sound frames over 256 data bytes: exception 03
    uint64_t collisions = 0;   // replies garbled by a second controller with the same ID
  };

  explicit Bus(const LineConfig& line = {}, const FaultConfig& faults = {});

  // Adds controller `id` (1–255). Throws lec6::InvalidArgument for ID 0 or a
  // duplicate, and for a config that validate() refuses.
  Controller& add(uint8_t id, const ActuatorConfig& config = {}, TimePoint power_on = TimePoint{},
                  const std::optional<Eeprom>& eeprom = std::nullopt);
  Controller* find(uint8_t id);
  const Controller* find(uint8_t id) const;
  std::vector<uint8_t> ids() const;

  // Every controller's EEPROM, by ID (what a state file holds), and a number
  // that changes whenever any of them changes (save when it moved).
  std::map<uint8_t, Eeprom> eeproms() const;
  uint64_t eeprom_generation() const;

  // Bytes from the master; `arrival` is when the chunk's last byte arrived.
  void receive(std::span<const uint8_t> bytes, TimePoint arrival);

  // Completes the frames whose silent interval has run out by `now`, acts on
  // them (each at the instant its frame was complete: last byte + Ts in real
  // timing, last byte in fast timing), and advances every controller to `now`.
  void advance(TimePoint now);

  // Removes and returns the replies due to start by `now`, in order.
  std::vector<Reply> take_replies(TimePoint now);

  // The earliest instant something on the line is due: a frame's silent
  // interval running out, a reply's start, the next noise byte. nullopt when
  // nothing is pending.
  // (Motion needs no wake-ups: controllers are evaluated when asked.)
  std::optional<TimePoint> next_deadline() const;

  // When a controller changes a flag by itself next (for a UI that redraws).
  std::optional<TimePoint> next_model_event() const;

  // Cuts controller `id` off the line (a broken cable, a connector pulled):
  // it hears nothing and answers nothing until joined again, while its axis
  // goes on with what it was doing. Fault injection (lec cycle's faults).
  void set_cut_off(uint8_t id, bool cut_off);
  bool cut_off(uint8_t id) const { return cut_off_.count(id) > 0; }

  const LineConfig& line() const { return line_; }
  const FaultConfig& faults() const { return faults_; }
  void set_faults(const FaultConfig& f);
  const Stats& stats() const { return stats_; }

 private:
  void act_on(const modbus::DeviceFramer::Frame& frame);
  void answer_too_long(const modbus::DeviceFramer::Frame& frame, TimePoint reply_start);
  void schedule(uint8_t id, modbus::Bytes bytes, TimePoint start);
  void queue(Reply r);
  // Idle-line noise (FaultConfig::noise_rate).
  bool noisy() const noexcept { return faults_.noise_rate > 0; }
  void make_noise(TimePoint until);
  void skip_noise(TimePoint until);
  void draw_noise_after(TimePoint t);

  // The controller `id` when it is on the line and not cut off.
  Controller* listening(uint8_t id);

  LineConfig line_;
  FaultConfig faults_;
  std::set<uint8_t> cut_off_;
  std::mt19937_64 rng_;
  modbus::DeviceFramer framer_;
  std::map<uint8_t, std::unique_ptr<Controller>> controllers_;
  std::vector<Reply> pending_;  // sorted by start
  TimePoint line_free_{};       // our last reply's end (half duplex)
  TimePoint last_reply_start_{};
  std::mt19937_64 noise_rng_;
  std::optional<TimePoint> next_noise_;  // when the next noise byte has fully arrived
  Stats stats_;
};

// For virtual-time drivers and tests: the query's first byte leaves at
// `start`, its last byte arrives after its wire time; the bus then runs until
// the first reply has fully arrived, or until `timeout` after the query's end.
// Returns that reply (its `end` is when the master has it), or nullopt
// (broadcast, silence, a dropped reply). Any other reply due by then, and any
// idle-line noise, is discarded.
std::optional<Reply> transact(Bus& bus, std::span<const uint8_t> query, TimePoint start,
                              Duration timeout = std::chrono::milliseconds(1000));

}  // namespace lec6::sim
