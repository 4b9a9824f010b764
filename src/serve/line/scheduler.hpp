#pragma once
// The heart of lec serve: who gets the RS485 line next (sans-I/O).
//
// One transaction at a time per line. Requests queue by priority (priority.hpp):
// stop/hold writes first, then client commands (taking turns by who sent
// them: command_turns.hpp), move-completion polling,
// telemetry (round-robin over IDs at their rates, earliest due first) and
// background reads. A request never splits: a write of several registers is
// one FC10, one transaction.
//
// Nothing starves: once a completion poll, a due telemetry read or a probe
// has waited `poll_max_wait` (a background read: `background_max_wait`),
// client commands, completion polls and reads (telemetry, probes, background;
// whichever waited longer first) take turns, one transaction each, skipping
// a kind with nothing queued (reads: nothing due), until nothing has waited
// that long.
// Otherwise clients that keep the line full (SCADA polling uncached
// registers) would stop every move from ever seeing its end and every axis's
// telemetry with it, and a move's back-to-back completion polls would take
// the line from the other axes' telemetry. Emergency writes never wait.
//
// A controller that stops answering is backed off: after `offline_after`
// consecutive failed exchanges it is offline; requests for it fail at once
// (Failure::Offline) and it is probed once per `probe_interval` until it
// answers. So a dead device costs the others at most one timeout per probe
// interval.
//
// Emergency jobs (stop, hold, reset: client::stops_or_releases) are the
// exception to every refusal but two: they go to an offline controller (its
// replies may be what is lost; the job counts as a probe), stay queued when
// their controller goes offline, go ahead of everything, and get at least
// `emergency_attempts` exchanges. Only a port that is gone (LineDown) or a
// shutdown fails them, and the result says so.
//
// Reads of the telemetry blocks may be answered from the cache
// (telemetry_cache.hpp) when the request allows it (Job::max_cache_age):
// at submit, and again when their turn comes (what they read may have come
// in meanwhile, e.g. by another client's read of the same block).
//
// The scheduler never reads a clock, never blocks, never calls back while it
// runs: completions and telemetry events are collected and handed out by
// take_completions() / take_events(), so its driver (serve::Line, or a test
// on a virtual clock) calls them outside its lock.
//
//   auto d = s.next(now);                   // a job to put on the wire, or nothing
//   ... exchange d->frame on the line ...
//   s.completed(reply, start, end) / s.failed(error, start, end);
//   for (auto& c : s.take_completions()) c.done(c.result);
//
// Thread safety: none; its driver serialises every call.

#include <array>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "lec6/client/errors.hpp"
#include "lec6/clock.hpp"
#include "lec6/modbus/pdu.hpp"
#include "lec6/modbus/timing.hpp"
#include "line/command_turns.hpp"
#include "line/emergency_lane.hpp"
#include "line/job.hpp"
#include "line/line_stats.hpp"
#include "line/priority.hpp"
#include "line/telemetry_cache.hpp"

namespace lec6::serve {

// Why a job got no reply from its controller.
enum class Failure : uint8_t {
  None,
  NoAnswer,      // the exchange failed on the line (timeout, CRC, framing) after its attempts
  Offline,       // the controller is backed off: refused at once
  LineDown,      // the port is gone (unplugged adapter); being reopened
  Cancelled,     // the submitter cancelled it before it started (client gone)
  ShuttingDown,  // lec serve is stopping
  Superseded,    // a write that starts motion, still queued when a stop to its controller came
};
std::string_view failure_name(Failure f) noexcept;

struct JobResult {
  Failure failure = Failure::None;
  std::optional<modbus::ResponseFrame> reply;  // when failure == None (may be an exception reply)
  client::TransportErrorKind error_kind = client::TransportErrorKind::Timeout;
  std::string error;  // for failures, in the user's terms
  bool from_cache = false;
  // started: when the exchange began (for a cache answer, when its block was
  // read): what the answer shows is no older than this.
  TimePoint submitted{}, started{}, finished{};
};

struct AxisSchedule {
  uint8_t id = 1;
  Duration telemetry_period{};  // zero: no telemetry for this axis
  // How it reports X4F: what the cache's snapshots (and the alarm-history
  // read an alarm triggers) read ALARM with.
  lec::AlarmPolarity alarm_polarity = lec::AlarmPolarity::ActiveHigh;
};

struct SchedulerConfig {
  std::vector<AxisSchedule> axes;
  unsigned offline_after = 3;                                 // consecutive failed exchanges
  Duration probe_interval = std::chrono::seconds(2);          // of an offline controller
  Duration controls_period = std::chrono::milliseconds(500);  // Y10–Y30 within telemetry
  Duration background_max_wait = std::chrono::seconds(1);     // then it goes before telemetry
  Duration poll_max_wait = std::chrono::milliseconds(100);    // then polls take turns with commands
  // Exchanges an Emergency job (stop, hold, reset) gets on a line fault, at
  // least: also to an offline controller (a lost reply must not cost the stop).
  int emergency_attempts = 3;
  // After a failed attempt to a controller that does not answer, its next
  // stop waits this long (emergency_lane.hpp): other controllers' stops and
  // other traffic go meanwhile.
  Duration emergency_backoff = std::chrono::milliseconds(250);
  modbus::LineTiming timing;  // for the utilisation figure
};

// The share of the line's limit that telemetry asks for at the configured
// rates: flags and state of each axis every period, its controls every
// controls_period. Above 1 the line cannot carry it: each axis gets about
// its rate / demand, and client commands take turns with it.
double telemetry_demand(const SchedulerConfig& config);

// The job now on the wire.
struct Dispatch {
  JobId id = 0;
  modbus::RequestFrame frame;
  Priority priority = Priority::Command;
};

// A controller's health as the scheduler sees it.
struct DeviceHealth {
  bool offline = false;
  unsigned consecutive_failures = 0;
  TimePoint next_probe{};     // when offline
  TimePoint offline_since{};  // when offline
  std::string last_error;
};

// Something a telemetry observer wants to know: a block of an axis changed.
struct TelemetryEvent {
  uint8_t id = 0;
  Block block = Block::Flags;
  bool flags_changed = false;  // Block::Flags and the bits differ from the previous read
  bool online_changed = false;
  TimePoint at{};       // the read's reply ended (on the line's thread)
  TimePoint started{};  // the read began ({}: at): what it shows was sampled in between
};

struct PendingCompletion {
  std::function<void(const JobResult&)> done;
  JobResult result;
};

class Scheduler {
 public:
  Scheduler(SchedulerConfig config, TimePoint now);

  // Queues a job. A cache hit, an offline controller (except for an
  // Emergency job) or a down line complete it at once (collected like any
  // completion). Throws InvalidArgument for a job at Priority::Telemetry
  // (the scheduler's own reads: it would never be taken).
  JobId submit(Job job, TimePoint now);
  // Removes a job that has not started (its completion says Cancelled).
  // Returns false when it is on the wire or already done.
  bool cancel(JobId id, TimePoint now);

  // The next job to put on the wire at `now`, if any; it stays in flight
  // until completed() or failed().
  std::optional<Dispatch> next(TimePoint now);
  // When next() will have something without a new submit (telemetry due, a
  // probe); nullopt: only a submit can wake the line.
  std::optional<TimePoint> wake_at() const;
  bool in_flight() const noexcept { return flight_.has_value(); }

  void completed(const modbus::ResponseFrame& reply, TimePoint start, TimePoint end);
  void failed(const client::TransportError& error, TimePoint start, TimePoint end);

  // The port is gone / back. While down, jobs fail at once with LineDown.
  void line_down(const std::string& why, TimePoint now);
  void line_up(TimePoint now);
  bool is_line_down() const noexcept { return !line_down_.empty(); }
  // begin_shutdown came: only Emergency jobs are taken.
  bool shutting_down() const noexcept { return shutting_down_; }
  const std::string& down_reason() const noexcept { return line_down_; }
  // lec serve is stopping: every queued job but the stops fails with
  // ShuttingDown, and so do later submits but stops; the stops queued and
  // submitted go on reaching the wire (issue 31 rule 4) until shut_down().
  void begin_shutdown(TimePoint now);
  // No stop queued nor any job on the wire (after begin_shutdown(): the line may close).
  bool drained() const noexcept { return !flight_ && lane_.empty(); }
  // Fails every queued job, the stops too, with ShuttingDown; later submits fail likewise.
  void shut_down(TimePoint now);
  // Whether next(now) has something to put on the wire.
  bool ready(TimePoint now) const;

  std::vector<PendingCompletion> take_completions();
  std::vector<TelemetryEvent> take_events();

  const TelemetryCache& cache() const noexcept { return cache_; }
  DeviceHealth health(uint8_t id) const;
  // When the last hard stop (RESET <- 1, HOLD <- 1, SVON <- 0) to `id` or to
  // every controller (a broadcast) was accepted, dated as superseded() dates
  // it; nullopt: none yet. A machine cycle in lec serve ends on one
  // (serve/cycles/): a Modbus TCP client's stop goes nowhere else.
  std::optional<TimePoint> last_hard_stop(uint8_t id) const {
    std::optional<TimePoint> at;
    for (const uint8_t to : {id, modbus::kBroadcastId}) {
      const auto it = hard_stop_.find(to);
      if (it != hard_stop_.end() && (!at || it->second.accepted > *at)) at = it->second.accepted;
    }
    return at;
  }
  LineStatsSnapshot stats(TimePoint now) const;
  DeviceCounters device_counters(uint8_t id) const { return stats_.device(id); }
  std::array<std::size_t, kPriorities> queue_depth() const;
  const SchedulerConfig& config() const noexcept { return config_; }
  // The sources whose turns it keeps (CommandTurns::known): bounded, however
  // many come and go (its forget_idle). What a test can see of the forgetting:
  // a source forgotten had nothing queued, and comes back behind the others
  // either way.
  std::size_t command_sources() const noexcept { return turns_.known(); }

 private:
  struct Flight {
    JobId id;
    Job job;
    TimePoint submitted;
    bool internal;  // telemetry, probe or background read: no client waits
  };
  // A telemetry read or probe (not a background read: an alarm history read
  // must not move or cut short an axis's telemetry sample).
  static bool is_telemetry(const Flight& f) {
    return f.internal && f.job.priority == Priority::Telemetry;
  }
  struct Telemetry {
    AxisSchedule schedule;
    TimePoint due{};
    std::vector<Block> pass;  // blocks still to read in the pass under way
  };

  // A read the scheduler makes itself (telemetry, probes, alarm history): no
  // client waits for it.
  static Job internal_read(Priority p, uint8_t id, Block b);
  std::optional<Dispatch> dispatch(Queued q, bool internal, TimePoint now);
  std::optional<Dispatch> pop(Priority p, TimePoint now);
  // Who goes when a poll waited too long: these take turns, in this order.
  enum class Turn : uint8_t { Command, Completion, Reads };  // Reads: telemetry, background
  static constexpr int kTurns = 3;
  struct Starved {
    bool completion = false;        // a completion poll waited poll_max_wait
    std::optional<Priority> reads;  // Telemetry or Background: which waited longer
  };
  Starved starved(TimePoint now) const;
  std::optional<Dispatch> take_turn(Turn turn, std::optional<Priority> reads, TimePoint now);
  std::optional<Dispatch> next_read(TimePoint now, std::optional<Priority> first);
  std::optional<Dispatch> next_background(TimePoint now);
  std::optional<Dispatch> next_telemetry(TimePoint now);
  std::optional<TimePoint> read_due(uint8_t id, const Telemetry& t) const;
  void start_pass(Telemetry& t, TimePoint now);
  void finish(JobResult result);
  void record(const Flight& f, TimePoint start, TimePoint end, ExchangeResult r);
  void note_reply(const Flight& f, const modbus::ResponseFrame& reply, TimePoint start,
                  TimePoint end);
  bool note_failure(uint8_t id, const std::string& why, TimePoint now);
  void fail_queued(uint8_t id, Failure why, const std::string& text, TimePoint now);
  void fail_all_queued(Failure why, const std::string& text, TimePoint now);
  void fail_one(Queued& x, Failure why, const std::string& text, TimePoint now);
  // A write that starts motion, submitted before a hard stop to its
  // controller was accepted: refused with Failure::Superseded (submit()).
  bool superseded(const Job& job, JobId id) const;
  // Whether a hard stop to its controller was accepted at or after `since`.
  bool superseded_since(const Job& job, TimePoint since) const;
  // `lost`: its reply was lost, and it is not sent again.
  void supersede(Job& job, TimePoint submitted, TimePoint now, bool lost = false);
  std::optional<JobResult> refuse_now(const Job& job, TimePoint now) const;
  bool answer_from_cache(Job& job, TimePoint submitted, TimePoint now);
  void complete(Job& job, JobResult result);

  SchedulerConfig config_;
  std::array<std::deque<Queued>, kPriorities> queues_;  // Emergency: lane_
  CommandTurns turns_;                                  // whose command goes next
  EmergencyLane lane_;
  std::optional<Flight> flight_;
  std::map<uint8_t, Telemetry> telemetry_;
  std::map<uint8_t, DeviceHealth> health_;
  struct HardStop {
    JobId id = 0;
    TimePoint accepted{};
  };
  std::map<uint8_t, HardStop> hard_stop_;  // the last hard stop accepted, per ID (0: broadcast)
  std::optional<HardStop> any_hard_stop_;  // the last one to any ID (a broadcast start's)
  TelemetryCache cache_;
  LineStats stats_;
  std::vector<PendingCompletion> completions_;
  std::vector<TelemetryEvent> events_;
  std::string line_down_;         // non-empty: why the line is down
  bool shutting_down_ = false;    // only stops are taken
  bool closed_ = false;           // nothing is taken
  Turn last_turn_ = Turn::Reads;  // the kind of the last dispatch (for taking turns)
  JobId next_id_ = 1;
};

}  // namespace lec6::serve
