#include "line/scheduler.hpp"

#include <fmt/format.h>

#include <algorithm>

#include "lec6/client/interrupt.hpp"
#include "lec6/error.hpp"

namespace lec6::serve {
namespace {

using client::TransportErrorKind;

std::size_t query_bytes(const modbus::RequestFrame& f) {
  const auto bytes = modbus::encode_request(f);
  return bytes ? bytes->size() : 8;
}

// The fastest a master that keeps the manual's rules can do this exchange:
// the digest §1 limit, plus the silent interval it must leave before its
// next query (so 1.0 is reachable by a compliant master, and only by one).
Duration limit_of(const modbus::LineTiming& t, const modbus::RequestFrame& f) {
  const std::size_t reply = f.id == modbus::kBroadcastId ? 0 : expected_response_length(f.pdu);
  return t.transaction_limit(query_bytes(f), reply) + t.silent_interval();
}

ExchangeResult result_of(TransportErrorKind k) {
  switch (k) {
    case TransportErrorKind::Timeout:
      return ExchangeResult::Timeout;
    case TransportErrorKind::Crc:
      return ExchangeResult::Crc;
    case TransportErrorKind::Framing:
      return ExchangeResult::Framing;
    default:
      return ExchangeResult::Other;
  }
}

}  // namespace

Job Scheduler::internal_read(Priority p, uint8_t id, Block b) {
  Job j;
  j.priority = p;
  j.frame = {id, block_request(b)};
  return j;
}

std::string_view failure_name(Failure f) noexcept {
  switch (f) {
    case Failure::None:
      return "none";
    case Failure::NoAnswer:
      return "no answer";
    case Failure::Offline:
      return "offline";
    case Failure::LineDown:
      return "line down";
    case Failure::Cancelled:
      return "cancelled";
    case Failure::ShuttingDown:
      return "shutting down";
    case Failure::Superseded:
      return "superseded by a stop";
  }
  return "failure";
}

Scheduler::Scheduler(SchedulerConfig config, TimePoint now)
    : config_(std::move(config)), lane_(config_.emergency_backoff), stats_(now) {
  for (const AxisSchedule& a : config_.axes) {
    telemetry_[a.id] = Telemetry{a, now, {}};
    cache_.set_alarm_polarity(a.id, a.alarm_polarity);
    health_[a.id];
    // Read each alarm history once at start, in the background.
    if (a.telemetry_period > Duration{}) {
      queues_[index(Priority::Background)].push_back(
          Queued{0, internal_read(Priority::Background, a.id, Block::Alarms), now});
    }
  }
}

void Scheduler::complete(Job& job, JobResult result) {
  if (job.done) completions_.push_back({std::move(job.done), std::move(result)});
}

std::optional<JobResult> Scheduler::refuse_now(const Job& job, TimePoint now) const {
  JobResult r;
  r.submitted = r.started = r.finished = now;
  if (closed_ || (shutting_down_ && job.priority != Priority::Emergency)) {
    r.failure = Failure::ShuttingDown;
    r.error_kind = TransportErrorKind::Port;
    r.error = "lec serve is shutting down";
    return r;
  }
  if (!line_down_.empty()) {
    r.failure = Failure::LineDown;
    r.error_kind = TransportErrorKind::Port;
    r.error = line_down_;
    return r;
  }
  // A stop, hold or reset goes to a controller that stopped answering too:
  // only its replies may be lost (noise, a drive switching), and it counts as
  // a probe. Only a port that is gone or a shutdown refuses it (above).
  if (job.priority == Priority::Emergency) return std::nullopt;
  const uint8_t id = job.frame.id;
  const auto h = health_.find(id);
  if (id != modbus::kBroadcastId && h != health_.end() && h->second.offline) {
    r.failure = Failure::Offline;
    r.error_kind = TransportErrorKind::Timeout;
    r.error = fmt::format(
        "controller ID {} is not answering: backed off after {} failed exchanges ({}); next probe "
        "in {:.1f} s",
        id, h->second.consecutive_failures, h->second.last_error,
        std::max(0.0, to_seconds(h->second.next_probe - now)));
    return r;
  }
  return std::nullopt;
}

JobId Scheduler::submit(Job job, TimePoint now) {
  if (job.priority == Priority::Telemetry) {
    // Telemetry is the scheduler's own round-robin, not a queue: such a job
    // would never be taken, and its line would spin.
    throw InvalidArgument(
        "a job cannot be submitted at Priority::Telemetry (the scheduler's own reads): use "
        "Command, Completion or Background");
  }
  const JobId id = next_id_++;
  if (job.priority == Priority::Emergency) {
    job.attempts = std::max(job.attempts, config_.emergency_attempts);
  }
  if (auto refused = refuse_now(job, now)) {
    complete(job, std::move(*refused));
    return id;
  }
  // A resend of a lost start, or a start of a command accepted before a
  // stop that came meanwhile: refused as the stop would have refused it queued.
  if ((job.first_submitted || job.command_accepted) && superseded(job, id)) {
    const bool lost = job.first_submitted && superseded_since(job, *job.first_submitted);
    supersede(job, now, now, lost);
    return id;
  }
  if (job.priority == Priority::Emergency) {
    // A hard stop (RESET <- 1, HOLD <- 1, SVON <- 0) supersedes the writes
    // queued before it that would start or resume motion (DRIVE, SETUP, JOG,
    // SVON <- 1, HOLD <- 0, a D9100 start) on its controller: its own, a
    // broadcast's, or any one's for a broadcast stop. They are refused, not
    // sent, wherever they wait (a queue, or the lane, where a release moved
    // them), and so is a resend of one whose reply was lost. Sending them
    // first, in order, put a start on the wire ahead of the stop the operator
    // pressed, and made each stop wait for every start a PLC had queued to
    // that controller (issue 31, rule 2: p99 888 ms in the line simulation).
    // The controller's other writes queued before the stop (step data,
    // IN0-IN5, Y30) still go first, in order, and a release (RESET, DRIVE,
    // JOG <- 0) refuses nothing: it ends a pulse, and the DRIVE <- 1 it ends
    // must go. Decision row: docs/protocol-decisions.md, "A stop supersedes".
    const uint8_t to = job.frame.id;
    if (client::stops_hard(job.frame.pdu)) {
      // Dated when its command was accepted, for one of lec serve's own
      // operations (a RESET pulse's RESET <- 1 follows its RESET <- 0's
      // exchange: a move accepted in between came after the reset, and must
      // go); never moved back by a later write of an earlier stop.
      const TimePoint at = std::min(now, job.command_accepted.value_or(now));
      const auto record = [&](std::optional<HardStop> before) {
        return HardStop{id, before ? std::max(before->accepted, at) : at};
      };
      const auto it = hard_stop_.find(to);
      hard_stop_[to] =
          record(it == hard_stop_.end() ? std::nullopt : std::optional<HardStop>(it->second));
      any_hard_stop_ = record(any_hard_stop_);
    }
    const auto reaches_id = [&](uint8_t target) {
      return target == to || to == modbus::kBroadcastId || target == modbus::kBroadcastId;
    };
    // What this stop refuses: the starts to its controller, and those of work
    // whose group has it (Job::stop_group).
    const auto reaches = [&](const Job& j) {
      return reaches_id(j.frame.id) ||
             std::find(j.stop_group.begin(), j.stop_group.end(), to) != j.stop_group.end();
    };
    for (Queued& q :
         lane_.take_if([&](const Queued& q) { return reaches(q.job) && superseded(q.job, q.id); }))
      supersede(q.job, q.submitted, now);
    std::vector<Queued> earlier;
    for (auto& q : queues_) {
      for (auto it = q.begin(); it != q.end();) {
        const bool write = modbus::is_write(it->job.frame.pdu);
        if (write && reaches(it->job) && superseded(it->job, it->id)) {
          supersede(it->job, it->submitted, now);
          it = q.erase(it);
        } else if (write && reaches_id(it->job.frame.id)) {
          earlier.push_back(std::move(*it));
          it = q.erase(it);
        } else {
          ++it;
        }
      }
    }
    std::sort(earlier.begin(), earlier.end(),
              [](const Queued& a, const Queued& b) { return a.id < b.id; });
    for (Queued& q : earlier) lane_.push_in_order(std::move(q), to);
    lane_.push(Queued{id, std::move(job), now});
    return id;
  }
  if (answer_from_cache(job, now, now)) return id;
  if (job.priority == Priority::Command) {
    auto& commands = queues_[index(Priority::Command)];
    // Sources whose jobs were cancelled, failed or superseded are forgotten
    // once there are more than the queue could hold (command_turns.hpp).
    if (turns_.known() > commands.size() + 64) turns_.forget_idle(commands);
    const JobSource source = job.source;
    turns_.queued(source, std::any_of(commands.begin(), commands.end(), [source](const Queued& x) {
                    return x.job.source == source;
                  }));
  }
  queues_[index(job.priority)].push_back(Queued{id, std::move(job), now});
  return id;
}

// A read the cache may answer and can: completed from it. Checked at submit
// and again when the job's turn comes, so clients that missed together (50
// SCADA masters polling one stale block) cost the line one read, not fifty.
bool Scheduler::answer_from_cache(Job& job, TimePoint submitted, TimePoint now) {
  if (job.max_cache_age <= Duration{}) return false;
  auto hit = cache_.lookup(job.frame.id, job.frame.pdu, job.max_cache_age, now, job.not_before);
  if (!hit) return false;
  stats_.cache_hit();
  stats_.latency(job.priority, now - submitted);
  JobResult r;
  r.reply = modbus::ResponseFrame{job.frame.id, std::move(hit->response)};
  r.from_cache = true;
  r.submitted = submitted;
  r.finished = now;
  r.started = hit->taken;
  complete(job, std::move(r));
  return true;
}

// Stops are not in queues_: an accepted stop is never cancelled (issue 31
// rule 4: a PLC that hangs up after writing HOLD still holds its axis).
bool Scheduler::cancel(JobId id, TimePoint now) {
  for (auto& q : queues_) {
    const auto it = std::find_if(q.begin(), q.end(), [&](const Queued& x) { return x.id == id; });
    if (it == q.end()) continue;
    JobResult r;
    r.failure = Failure::Cancelled;
    r.error = "cancelled before it reached the line";
    r.submitted = it->submitted;
    r.started = r.finished = now;
    complete(it->job, std::move(r));
    q.erase(it);
    return true;
  }
  return false;
}

void Scheduler::record(const Flight& f, TimePoint start, TimePoint end, ExchangeResult r) {
  stats_.exchange(f.job.frame.id, start, end, limit_of(config_.timing, f.job.frame), r);
  if (f.job.done || f.internal) stats_.latency(f.job.priority, end - f.submitted);
}

void Scheduler::note_reply(const Flight& f, const modbus::ResponseFrame& reply, TimePoint start,
                           TimePoint end) {
  const uint8_t id = f.job.frame.id;
  if (std::holds_alternative<modbus::ExceptionResponse>(reply.pdu)) return;
  if (modbus::is_write(f.job.frame.pdu)) {
    id == modbus::kBroadcastId ? cache_.invalidate_all(end) : cache_.invalidate(id, end);
    return;
  }
  const auto before = cache_.snapshot(id).flags;
  const auto block = cache_.update(id, f.job.frame.pdu, reply.pdu, start);
  if (!block) return;
  TelemetryEvent e{id, *block, false, false, end, start};
  if (*block == Block::Flags) {
    const auto after = cache_.snapshot(id).flags;
    e.flags_changed = !before || before->bits != after->bits;
    // An alarm appeared: fetch its history entry in the background.
    if (after->alarm() && (!before || !before->alarm())) {
      queues_[index(Priority::Background)].push_back(
          Queued{0, internal_read(Priority::Background, id, Block::Alarms), end});
    }
  }
  events_.push_back(e);
}

void Scheduler::completed(const modbus::ResponseFrame& reply, TimePoint start, TimePoint end) {
  if (!flight_) return;
  Flight f = std::move(*flight_);
  flight_.reset();
  const uint8_t id = f.job.frame.id;
  const bool exception = std::holds_alternative<modbus::ExceptionResponse>(reply.pdu);
  record(f, start, end, exception ? ExchangeResult::Exception : ExchangeResult::Answered);
  if (id != modbus::kBroadcastId) {
    DeviceHealth& h = health_[id];
    if (h.offline) events_.push_back({id, Block::Flags, false, true, end});
    h = DeviceHealth{};
  }
  note_reply(f, reply, start, end);
  if (const auto t = telemetry_.find(id);
      is_telemetry(f) && t != telemetry_.end() && t->second.pass.empty()) {
    Telemetry& tel = t->second;
    tel.due =
        std::max(tel.due + tel.schedule.telemetry_period, end - tel.schedule.telemetry_period);
  }
  JobResult r;
  r.reply = reply;
  r.submitted = f.submitted;
  r.started = start;
  r.finished = end;
  complete(f.job, std::move(r));
}

// Counts a failed exchange; returns true when the controller just went
// offline (its queued jobs are failed by the caller, after the one on the wire).
bool Scheduler::note_failure(uint8_t id, const std::string& why, TimePoint now) {
  if (id == modbus::kBroadcastId) return false;
  // Every controller that can go offline can be probed back, telemetry or not.
  telemetry_.try_emplace(id, Telemetry{AxisSchedule{id, Duration{}}, now, {}});
  DeviceHealth& h = health_[id];
  ++h.consecutive_failures;
  h.last_error = why;
  if (h.offline) {
    h.next_probe = now + config_.probe_interval;
    return false;
  }
  if (h.consecutive_failures < config_.offline_after) return false;
  h.offline = true;
  h.offline_since = now;
  h.next_probe = now + config_.probe_interval;
  events_.push_back({id, Block::Flags, false, true, now});
  return true;
}

void Scheduler::failed(const client::TransportError& error, TimePoint start, TimePoint end) {
  if (!flight_) return;
  Flight f = std::move(*flight_);
  flight_.reset();
  const uint8_t id = f.job.frame.id;
  record(f, start, end, result_of(error.kind()));
  if (const auto t = telemetry_.find(id); is_telemetry(f) && t != telemetry_.end()) {
    Telemetry& tel = t->second;
    tel.pass.clear();  // the sample is lost; the next one comes at the next period
    tel.due =
        std::max(tel.due + tel.schedule.telemetry_period, end - tel.schedule.telemetry_period);
  }
  JobResult r;
  r.error_kind = error.kind();
  r.error = error.what();
  r.submitted = f.submitted;
  r.started = start;
  r.finished = end;
  if (!client::is_line_fault(error.kind())) {
    r.failure = Failure::LineDown;
    complete(f.job, std::move(r));
    line_down(error.what(), end);
    return;
  }
  const bool went_offline = note_failure(id, error.what(), end);
  const bool offline = id != modbus::kBroadcastId && health_[id].offline;
  // A stop keeps its attempts on an offline controller: a lost reply must not cost the stop.
  const bool emergency = f.job.priority == Priority::Emergency;
  if (!f.internal && f.job.attempts > 1 && (!offline || emergency)) {
    --f.job.attempts;
    if (superseded(f.job, f.id)) {
      // Its reply was lost while a stop to its controller came: the stop went
      // (or goes) first, and the start is not sent after it.
      supersede(f.job, f.submitted, end, true);
      return;
    }
    if (emergency) {
      // Other controllers' stops go first; a controller that stopped
      // answering waits its backoff (emergency_lane.hpp).
      lane_.retry(Queued{f.id, std::move(f.job), f.submitted, true}, !offline, end);
    } else {
      queues_[index(f.job.priority)].push_front(Queued{f.id, std::move(f.job), f.submitted, true});
    }
    return;
  }
  r.failure = offline && f.job.attempts > 1 && !emergency ? Failure::Offline : Failure::NoAnswer;
  complete(f.job, std::move(r));
  if (went_offline) {
    const DeviceHealth& h = health_[id];
    fail_queued(
        id, Failure::Offline,
        fmt::format("controller ID {} stopped answering ({} failed exchanges: {}); backed "
                    "off, probed every {:.1f} s",
                    id, h.consecutive_failures, h.last_error, to_seconds(config_.probe_interval)),
        end);
  }
}

// Stops, holds and resets stay queued: they go to an offline controller too.
void Scheduler::fail_queued(uint8_t id, Failure why, const std::string& text, TimePoint now) {
  for (auto& q : queues_) {
    for (auto it = q.begin(); it != q.end();) {
      if (it->job.frame.id != id || it->job.priority == Priority::Emergency) {
        ++it;
        continue;
      }
      JobResult r;
      r.failure = why;
      r.error_kind = TransportErrorKind::Timeout;
      r.error = text;
      r.submitted = it->submitted;
      r.started = r.finished = now;
      complete(it->job, std::move(r));
      it = q.erase(it);
    }
  }
}

// Answers a queued job that will not reach the wire.
void Scheduler::fail_one(Queued& x, Failure why, const std::string& text, TimePoint now) {
  JobResult r;
  r.failure = why;
  r.error_kind = TransportErrorKind::Port;
  r.error = text;
  r.submitted = x.submitted;
  r.started = r.finished = now;
  complete(x.job, std::move(r));
}

bool Scheduler::superseded_since(const Job& job, TimePoint since) const {
  if (job.priority == Priority::Emergency || !client::starts_motion(job.frame.pdu)) return false;
  const auto after = [&](const HardStop& s) { return s.accepted >= since; };
  if (job.frame.id == modbus::kBroadcastId) return any_hard_stop_ && after(*any_hard_stop_);
  for (const uint8_t to : {job.frame.id, modbus::kBroadcastId}) {
    const auto it = hard_stop_.find(to);
    if (it != hard_stop_.end() && after(it->second)) return true;
  }
  return false;
}

bool Scheduler::superseded(const Job& job, JobId id) const {
  if (job.priority == Priority::Emergency || !client::starts_motion(job.frame.pdu)) return false;
  // A write of one of lec serve's operations is judged by when its command
  // was accepted, not by when it was queued: a stop accepted before the
  // command, whose write came after the command's start was queued (a
  // reset's RESET <- 1 follows its RESET <- 0's exchange), does not refuse it.
  const auto after = [&](const HardStop& s) {
    if (job.first_submitted && s.accepted >= *job.first_submitted) return true;
    if (job.command_accepted) return s.accepted >= *job.command_accepted;
    return s.id > id;
  };
  if (job.frame.id == modbus::kBroadcastId) return any_hard_stop_ && after(*any_hard_stop_);
  for (const uint8_t to : {job.frame.id, modbus::kBroadcastId}) {
    const auto it = hard_stop_.find(to);
    if (it != hard_stop_.end() && after(it->second)) return true;
  }
  for (const uint8_t to : job.stop_group) {  // a cycle's other axes
    const auto it = hard_stop_.find(to);
    if (it != hard_stop_.end() && after(it->second)) return true;
  }
  return false;
}

void Scheduler::supersede(Job& job, TimePoint submitted, TimePoint now, bool lost) {
  JobResult r;
  r.failure = Failure::Superseded;
  r.error_kind = TransportErrorKind::Port;
  r.error = lost
                ? fmt::format(
                      "its reply was lost, and a stop to ID {} came meanwhile: not sent again (a "
                      "stop supersedes the writes before it that would start or resume motion; the "
                      "controller may have heard the first attempt, and the stop came after it)",
                      job.frame.id)
                : fmt::format(
                      "not carried out: a stop to ID {} accepted after it came first (a stop "
                      "supersedes the writes before it that would start or resume motion: those "
                      "queued, and those of commands accepted before it)",
                      job.frame.id);
  r.submitted = submitted;
  r.started = r.finished = now;
  stats_.superseded(job.frame.id);
  complete(job, std::move(r));
}

void Scheduler::fail_all_queued(Failure why, const std::string& text, TimePoint now) {
  for (Queued& x : lane_.take_all()) fail_one(x, why, text, now);
  for (auto& q : queues_) {
    for (auto& x : q) fail_one(x, why, text, now);
    q.clear();
  }
  for (auto& [id, t] : telemetry_) t.pass.clear();
}

void Scheduler::line_down(const std::string& why, TimePoint now) {
  line_down_ = why.empty() ? "the line is down" : why;
  fail_all_queued(Failure::LineDown, line_down_, now);
}

void Scheduler::line_up(TimePoint now) {
  line_down_.clear();
  for (auto& [id, t] : telemetry_) t.due = now;
}

void Scheduler::begin_shutdown(TimePoint now) {
  shutting_down_ = true;
  for (auto& q : queues_) {
    for (auto& x : q) fail_one(x, Failure::ShuttingDown, "lec serve is shutting down", now);
    q.clear();
  }
  for (auto& [id, t] : telemetry_) t.pass.clear();
}

void Scheduler::shut_down(TimePoint now) {
  shutting_down_ = closed_ = true;
  fail_all_queued(Failure::ShuttingDown, "lec serve is shutting down", now);
}

bool Scheduler::ready(TimePoint now) const {
  if (flight_ || !line_down_.empty() || closed_) return false;
  if (lane_.ready(now)) return true;
  if (shutting_down_) return false;
  for (std::size_t p = 0; p < kPriorities; ++p)
    if (p != index(Priority::Emergency) && !queues_[p].empty()) return true;
  return false;
}

std::vector<PendingCompletion> Scheduler::take_completions() {
  return std::exchange(completions_, {});
}

std::vector<TelemetryEvent> Scheduler::take_events() {
  return std::exchange(events_, {});
}

DeviceHealth Scheduler::health(uint8_t id) const {
  const auto h = health_.find(id);
  return h == health_.end() ? DeviceHealth{} : h->second;
}

std::array<std::size_t, kPriorities> Scheduler::queue_depth() const {
  std::array<std::size_t, kPriorities> d{};
  for (std::size_t p = 0; p < kPriorities; ++p) d[p] = queues_[p].size();
  d[index(Priority::Emergency)] = lane_.size();
  return d;
}

double telemetry_demand(const SchedulerConfig& config) {
  const auto limit = [&](uint8_t id, Block b) {
    return to_seconds(limit_of(config.timing, {id, block_request(b)}));
  };
  double share = 0;
  for (const AxisSchedule& a : config.axes) {
    if (a.telemetry_period <= Duration{}) continue;
    share +=
        (limit(a.id, Block::Flags) + limit(a.id, Block::State)) / to_seconds(a.telemetry_period);
    share += limit(a.id, Block::Controls) / to_seconds(config.controls_period);
  }
  return share;
}

LineStatsSnapshot Scheduler::stats(TimePoint now) const {
  return stats_.snapshot(now, queue_depth());
}

}  // namespace lec6::serve
