#include "ops/operations.hpp"

#include <fmt/format.h>

#include <random>
#include <system_error>
#include <thread>

#include "history/motion_settings.hpp"  // issue 26: what the history groups moves by
#include "lec6/client/step_sync.hpp"
#include "lec6/lec/step_table.hpp"
#include "line/line_master.hpp"
#include "ops/op_results.hpp"
#include "ops/operation_slots.hpp"

namespace lec6::serve {

namespace {

const SteadyClock kClock;

OpResult judged(Op op, const client::StopReport& r) {
  // 200 only on evidence; otherwise 502: the stop went out, the axis says
  // otherwise, or could not be read.
  OpResult result{r.stopped ? 200 : 502, {{"ok", r.stopped}, {"op", op_name(op)}}};
  result.body[r.stopped ? "message" : "error"] = r.describe();
  result.body["stopped"] = r.stopped;
  result.body["actions"] = r.actions;
  if (r.answered) {
    result.body["position_mm"] = static_cast<double>(r.state.position_001mm) / 100.0;
    result.body["speed_mm_s"] = r.state.speed_mm_s;
  }
  result.body["took_s"] = to_seconds(r.took);
  return result;
}

// The operations a later one on the same axis waits for, and that never
// wait themselves: stop, reset, hold on, and servo off (SVON <- 0 is a hard
// stop too: an operator whose stop did not stop the axis turns the servo off,
// and that must not wait for the stop's judgement; a reviewer's finding).
bool stop_like(const Command& cmd) {
  return stops_motion(cmd) || (cmd.op == Op::Servo && !cmd.on);
}

// A motion a stop or reset for its axis came before: not started (422).
OpResult stopped_first(Op op) {
  auto r = refusal(422, fmt::format("{} not started: a stop or reset for this axis came first "
                                    "(through lec serve)",
                                    op_name(op)));
  r.body["outcome"] = "stopped";
  return r;
}

void renew(std::atomic<int64_t>& lease_until, Duration lease) {
  lease_until = (kClock.now() + lease).time_since_epoch().count();
}

}  // namespace

Operations::Operations(Log log, Duration after_stop_wait)
    : log_(std::move(log)), after_stop_wait_(after_stop_wait) {}

Operations::~Operations() {
  shutdown();
}

void Operations::add_observer(OpObserver observer) {
  std::lock_guard lock(mutex_);
  observers_.push_back(std::move(observer));
}

void Operations::notify(const std::string& axis, const nlohmann::json& event) {
  std::vector<OpObserver> observers;
  {
    std::lock_guard lock(mutex_);
    observers = observers_;
  }
  for (const auto& o : observers) o(axis, event);
}

void Operations::run(const AxisRef& axis, Command cmd, std::string source,
                     std::function<void(OpResult)> done) {
  std::optional<OpResult> at_once;
  std::shared_ptr<Running> run;
  {
    std::lock_guard lock(mutex_);
    Slot& slot = slots_[axis.name];
    // A stop, hold or reset is taken while lec serve shuts down: the line
    // sends stops until it closes (issue 31 rule 4).
    if (shutting_down_ && !stops_motion(cmd)) {
      at_once = refusal(503, "lec serve is shutting down: only stop, hold and reset are taken");
    } else if (cmd.op == Op::JogStop) {
      if (slot.motion && slot.motion->op == Op::Jog) slot.motion->cancel = true;
      at_once =
          OpResult{200,
                   {{"ok", true},
                    {"op", "jog-stop"},
                    {"message", slot.motion && slot.motion->op == Op::Jog ? "jog released"
                                                                          : "no jog was running"}}};
    } else if (is_motion(cmd.op) && !slot.motion && slot.unsettled &&
               !settled(axis, *slot.unsettled)) {
      at_once = unsettled_refusal(axis, *slot.unsettled);
    } else if (is_motion(cmd.op) && slot.motion) {
      Running& r = *slot.motion;
      if (cmd.op == Op::Jog && r.op == Op::Jog && r.jog_plus == cmd.jog_plus &&
          cmd.jog_lease > Duration{} && !r.cancel) {
        renew(r.lease_until, cmd.jog_lease);
        at_once = OpResult{200, {{"ok", true}, {"op", "jog"}, {"message", "jog lease renewed"}}};
      } else {
        const std::string waits = r.waiting ? r.waiting_for() : "";
        at_once = refusal(
            409,
            waits.empty()
                ? fmt::format("axis {} is busy: {} started {:.1f} s ago by {}; stop it "
                              "first (stop, or jog-stop for a jog)",
                              axis.name, r.name(), to_seconds(kClock.now() - r.since), r.source)
                : fmt::format("axis {} is busy: a {} by {}, accepted {:.1f} s ago, waits for "
                              "the {} accepted before it, and starts after it; stop it "
                              "first (stop, or jog-stop for a jog)",
                              axis.name, r.name(), r.source, to_seconds(kClock.now() - r.since),
                              waits));
      }
    } else {
      run = std::make_shared<Running>();
      run->op = cmd.op;
      run->source = source;
      run->since = kClock.now();
      run->accepted = axis.line->clock().now();
      run->jog_plus = cmd.jog_plus;
      if (cmd.op == Op::Jog && cmd.jog_lease > Duration{}) renew(run->lease_until, cmd.jog_lease);
      if (is_motion(cmd.op)) slot.motion = run, slot.unsettled.reset();
      std::erase_if(slot.stops, [](const auto& w) { return w.expired(); });
      if (stop_like(cmd)) {
        slot.stops.push_back(run);
      } else {
        for (const auto& w : slot.stops)
          if (const auto s = w.lock()) run->after.push_back({s->ended, s->op, s->source});
      }
      if (stops_motion(cmd) && slot.motion && slot.motion != run)
        slot.motion->stopped_by_other = true;
      if ((cmd.op == Op::Stop || cmd.op == Op::Reset) && slot.motion && slot.motion != run) {
        // A stop ends what moves: a jog releases JOG at once (issue 31 rule 6).
        slot.motion->stop_requested = true;
        if (slot.motion->op == Op::Jog) slot.motion->cancel = true;
      }
    }
  }
  if (at_once) return done(std::move(*at_once));
  nlohmann::json started{{"event", "started"}, {"op", op_name(cmd.op)}, {"source", source}};
  started.update(history::motion_settings(cmd));  // issue 26: the move's settings
  // One that waits for a stop says "started" when its wait is over: the
  // history dates a motion from it (it must not count the wait).
  if (run->after.empty()) {
    notify(axis.name, started);
    started = nullptr;
  }
  start_thread(axis, std::move(cmd), std::move(run), std::move(started), std::move(done));
}

void Operations::start_thread(const AxisRef& axis, Command cmd, std::shared_ptr<Running> run,
                              nlohmann::json started, std::function<void(OpResult)> done) {
  began_one();
  const Command cmd_copy = cmd;  // for a refusal, when no thread can be made
  const std::function<void(OpResult)> done_copy = done;
  auto body = [this, axis, cmd = std::move(cmd), run, started = std::move(started),
               done = std::move(done)] {
    OpResult result;
    try {
      if (auto refused = wait_for_stops(cmd, *run)) {
        result = std::move(*refused);
      } else {
        if (!started.is_null()) notify(axis.name, started);
        result = execute(axis, cmd, *run);
      }
    } catch (...) {
      result = result_of(std::current_exception(), run->stopped_by_other);
    }
    // Every result names its op, a failure too (an alarm's came without it,
    // and the dashboard titled it "command"; issue 27).
    if (!result.body.contains("op")) result.body["op"] = op_name(cmd.op);
    finished(axis, run, result);
    // After its "finished": what waited for it says "started" after that.
    run->ended_promise.set_value();
    done(result);
    ended_one();
  };
  try {
    std::thread(body).detach();  // a copy: `body` is whole if no thread can be made
  } catch (const std::system_error& e) {
    // No thread (the process is out of them). A stop, hold, reset or servo
    // off runs here, on the caller's thread (the event loop: it is short,
    // and must go); anything else is refused with nothing sent (a move run
    // here would block every other front-end's stops until it ended).
    if (stop_like(cmd_copy)) {
      log_(LogLevel::Warning, fmt::format("no thread for a {} ({}): it runs on the caller's",
                                          op_name(cmd_copy.op), e.what()));
      body();
    } else {
      log_(LogLevel::Warning,
           fmt::format("no thread for a {} ({}): refused", op_name(cmd_copy.op), e.what()));
      OpResult r = refusal(503, fmt::format("{}: not started: no thread ({}); nothing was sent",
                                            op_name(cmd_copy.op), e.what()));
      run->nothing_sent = true;  // its slot frees without "unsettled"
      finished(axis, run, r);
      run->ended_promise.set_value();
      ended_one();
      done_copy(std::move(r));
    }
  }
}

std::optional<OpResult> Operations::wait_for_stops(const Command& cmd, Running& run) const {
  if (run.after.empty()) return std::nullopt;
  {
    std::lock_guard lock(mutex_);
    run.waiting = true;
  }
  struct Started {  // running() and a 409 count from here once it goes
    std::mutex& m;
    Running& r;
    ~Started() {
      std::lock_guard lock(m);
      r.waiting = false;
      r.since = kClock.now();
    }
  } started{mutex_, run};
  // What ends it while it waits, checked between slices of the wait: a
  // stop accepted after it, a jog let go, lec serve shutting down. It then
  // ends with nothing sent (a reviewer's findings: a released jog kept the
  // axis busy until the stop it waited for ended; a move started while the
  // daemon went down).
  const auto ended_meanwhile = [&]() -> std::optional<OpResult> {
    {
      std::lock_guard lock(mutex_);
      if (shutting_down_)
        return refusal(503, fmt::format("{} not started: lec serve is shutting down (it waited "
                                        "for a stop accepted before it); nothing was sent",
                                        op_name(cmd.op)));
    }
    if (is_motion(cmd.op) && run.stop_requested.load()) return stopped_first(cmd.op);
    // A jog let go (jog-stop, its lease, its stream): JOG <- 1 then <- 0
    // after the button was released would twitch the axis.
    if (cmd.op == Op::Jog &&
        (run.cancel.load() || run.lease_expired(kClock.now()) || run.tie_closed())) {
      return OpResult{200,
                      {{"ok", true},
                       {"op", "jog"},
                       {"outcome", "released"},
                       {"message",
                        "jog released before it started (it waited for a stop accepted before "
                        "it): nothing was sent"}}};
    }
    return std::nullopt;
  };
  const TimePoint waited_from = kClock.now();
  const TimePoint until = waited_from + after_stop_wait_;
  // A command with a freshness rule (MQTT's valid_for) waits no longer than
  // it is valid: a late command never moves an axis.
  const TimePoint fresh_until = cmd.start_by.value_or(TimePoint::max());
  std::optional<OpResult> ended;
  for (const Running::Awaited& stop : run.after) {
    for (;;) {
      if ((ended = ended_meanwhile())) break;
      const TimePoint now = kClock.now();
      if (now >= fresh_until && fresh_until < until) {
        ended = refusal(
            408, fmt::format("{} not started: it waited {:.1f} s for the {} (by {}) accepted "
                             "before it on this axis, and is no longer valid (valid_for); "
                             "nothing was sent, so that a late command never moves an axis",
                             op_name(cmd.op), to_seconds(now - waited_from), op_name(stop.op),
                             stop.source));
        break;
      }
      if (now >= until) {
        ended = refusal(
            409, fmt::format("{} not started: it waited {:.1f} s for the {} (by {}) accepted "
                             "before it on this axis, which still runs; nothing was sent: send "
                             "it again once that has ended (a stop, hold, reset or servo off "
                             "goes first, so that the controller sees them in the order they "
                             "came)",
                             op_name(cmd.op), to_seconds(after_stop_wait_), op_name(stop.op),
                             stop.source));
        break;
      }
      const Duration slice = std::min<Duration>(
          {until - now, std::max(fresh_until, now) - now, Duration(std::chrono::milliseconds(20))});
      if (stop.ended.wait_for(slice) == std::future_status::ready) break;
    }
    if (ended) break;
  }
  if (!ended) ended = ended_meanwhile();
  if (ended) run.nothing_sent = true;
  return ended;
}

void Operations::run_task(const AxisRef& axis, std::string name, std::string source,
                          std::function<OpResult(client::Client&)> task,
                          std::function<void(OpResult)> done) {
  {
    std::lock_guard lock(mutex_);
    if (shutting_down_) return done(refusal(503, "lec serve is shutting down"));
  }
  began_one();
  if (name != "step-read" && name != "step-plan") {
    log_(LogLevel::Info, fmt::format("{} on {} by {}", name, axis.name, source));
  }
  const std::function<void(OpResult)> done_copy = done;  // when no thread can be made
  auto body = [this, axis, task = std::move(task), done = std::move(done)] {
    OpResult result;
    try {
      LineMaster master(*axis.line, Priority::Command, Priority::Command);
      client::ClientOptions co;
      co.id = axis.id;
      co.retries = axis.line_config->retries;
      co.alarm_polarity = axis.config->alarm_polarity;
      client::Client c(master, co);
      result = task(c);
    } catch (...) {
      result = result_of(std::current_exception(), false);
    }
    done(result);
    ended_one();
  };
  try {
    std::thread(body).detach();  // a copy: `body` is whole if no thread can be made
  } catch (const std::system_error& e) {
    log_(LogLevel::Warning, fmt::format("no thread for {} ({}): refused", name, e.what()));
    ended_one();
    done_copy(refusal(503, fmt::format("{}: not started: no thread ({})", name, e.what())));
  }
}

void Operations::finished(const AxisRef& axis, const std::shared_ptr<Running>& run,
                          const OpResult& result) {
  {
    std::lock_guard lock(mutex_);
    Slot& slot = slots_[axis.name];
    if (slot.motion == run) {
      slot.motion.reset();
      // 5xx: no answer, a deadline, the line down: nothing says the axis stopped.
      if (result.status >= 500 && !run->nothing_sent) {
        slot.unsettled = Unsettled{run->op, run->source, result.body.value("error", "no answer"),
                                   axis.line->clock().now()};
      }
    }
    if (is_motion(run->op)) slot.last = result.body;
  }
  nlohmann::json event = result.body;
  event["event"] = "finished";
  event["status"] = result.status;
  notify(axis.name, event);
}

bool Operations::settled(const AxisRef& axis, const Unsettled& u) const {
  const AxisSnapshot s = axis.line->snapshot(axis.id);
  return s.flags && s.flags_at > u.ended && !s.flags->busy();
}

OpResult Operations::unsettled_refusal(const AxisRef& axis, const Unsettled& u) const {
  const AxisSnapshot s = axis.line->snapshot(axis.id);
  const bool fresh = s.flags && s.flags_at > u.ended;
  if (!fresh) {
    // Ask the controller (no client waits): the next request finds the answer
    // in the cache, also on an axis without telemetry.
    Job read;
    read.priority = Priority::Command;
    read.frame = {axis.id, block_request(Block::Flags)};
    axis.line->submit(std::move(read));
  }
  return refusal(
      409,
      fmt::format("axis {} may still be moving: its {} (started by {}) ended {:.1f} s ago "
                  "without the axis seen stopped ({}); a new motion is accepted once a read "
                  "of its flags shows BUSY = 0 ({}); stop it to be sure",
                  axis.name, u.name(), u.source, to_seconds(axis.line->clock().now() - u.ended),
                  u.why, fresh ? "the last read shows BUSY = 1" : "no read since"));
}

void Operations::tie_jog(const std::string& axis, std::function<bool()> closed) {
  std::lock_guard lock(mutex_);
  const auto it = slots_.find(axis);
  if (it == slots_.end() || !it->second.motion || it->second.motion->op != Op::Jog) return;
  std::lock_guard tie(it->second.motion->tie_mutex);
  it->second.motion->tie = std::move(closed);
}

std::optional<OpStatus> Operations::running(const AxisRef& axis) const {
  std::lock_guard lock(mutex_);
  const auto it = slots_.find(axis.name);
  if (it == slots_.end()) return std::nullopt;
  if (!it->second.motion) {
    const auto& u = it->second.unsettled;
    if (!u || settled(axis, *u)) return std::nullopt;
    return OpStatus{u->name(), u->source, to_seconds(axis.line->clock().now() - u->ended), true,
                    ""};
  }
  const Running& r = *it->second.motion;
  OpStatus s{r.name(), r.source, to_seconds(kClock.now() - r.since), false, ""};
  if (r.waiting) s.waiting_for = r.waiting_for();
  return s;
}

std::optional<nlohmann::json> Operations::last_result(const std::string& axis) const {
  std::lock_guard lock(mutex_);
  const auto it = slots_.find(axis);
  return it == slots_.end() ? std::nullopt : it->second.last;
}

void Operations::begin_shutdown() {
  std::lock_guard lock(mutex_);
  shutting_down_ = true;
  for (auto& [name, slot] : slots_) {
    if (slot.motion && slot.motion->op == Op::Jog) slot.motion->cancel = true;
  }
}

void Operations::began_one() {
  std::lock_guard lock(active_mutex_);
  ++active_;
}

void Operations::ended_one() {
  std::lock_guard lock(active_mutex_);
  if (--active_ == 0) idle_.notify_all();
}

bool Operations::idle() const {
  std::lock_guard lock(active_mutex_);
  return active_ == 0;
}

void Operations::shutdown() {
  begin_shutdown();
  // Jogs release JOG and wait for the axis to stop; moves end when their
  // line answers "shutting down". Bounded: a dead line cannot hold us.
  std::unique_lock lock(active_mutex_);
  idle_.wait_for(lock, std::chrono::seconds(5), [this] { return active_ == 0; });
}

// ---- execution -----------------------------------------------------------------

client::StopPolicy Operations::stop_policy(const AxisRef& axis) {
  client::StopPolicy p;
  p.escalate_servo_off = axis.config->stop_servo_off;
  return p;
}

OpResult Operations::execute(const AxisRef& axis, const Command& cmd, Running& run) {
  // Stop, reset and hold (not HOLD off: it resumes motion) go at Emergency,
  // the reads that judge them too: behind other clients' requests a
  // judgement would wait for a SCADA flood (their writes would go first
  // anyway: priority_of, the one rule). They take their controller's turn in
  // the emergency lane, so other controllers' stops still go.
  const bool urgent = stops_motion(cmd);
  LineMaster master(*axis.line, urgent ? Priority::Emergency : Priority::Completion,
                    urgent ? Priority::Emergency : Priority::Command);
  // Its writes carry when it was accepted: a start's, so that a stop accepted
  // after it supersedes it; a stop's, so that it is dated then (scheduler.cpp).
  master.count_from(run.accepted);
  client::ClientOptions co;
  co.id = axis.id;
  co.retries = axis.line_config->retries;
  co.alarm_polarity = axis.config->alarm_polarity;
  client::Client c(master, co);
  client::Actuator act(c);
  if (const auto& l = axis.config->soft_limits_001mm)
    act.set_soft_limits(client::SoftLimits{l->first, l->second});
  const TimePoint deadline = kClock.now() + cmd.timeout;
  client::WaitOptions wait;
  // A move outlives a few lost polls: its controller, backed off after
  // `offline_after` failed exchanges on a noisy line, is probed again within
  // probe_interval, and the move's end is seen then (two probes' grace, at
  // least 5 s). Without it a burst of noise failed a move that went on to
  // reach its target (502), and the axis refused motion until a probe.
  wait.unanswered_grace = std::max<Duration>(
      std::chrono::seconds(5),
      2 * std::chrono::duration_cast<Duration>(
              std::chrono::duration<double, std::milli>(axis.line_config->probe_interval_ms)));
  // The polls of a motion come 0 to one flags read's transaction time later
  // than back to back, drawn anew each time: axes that move in step would
  // otherwise be polled at the same delay after their edges every move, and
  // the history's brackets of them never narrow from above (issue 32,
  // docs/history.md "Narrowed by the positions").
  // (Seeded per thread once: no system call in an operation, a stop's least
  // of all.) A flags read: FC02 of 16 inputs, an 8-byte query, a 7-byte reply.
  const Duration jitter_max = axis.line->timing().transaction_limit(8, 7);
  wait.poll_jitter = [jitter_max] {
    thread_local std::minstd_rand rng(static_cast<uint32_t>(
        std::hash<std::thread::id>{}(std::this_thread::get_id()) ^
        static_cast<std::size_t>(std::chrono::steady_clock::now().time_since_epoch().count())));
    return Duration(std::uniform_int_distribution<int64_t>(0, jitter_max.count())(rng));
  };
  if (cmd.op == Op::Home || cmd.op == Op::Move || cmd.op == Op::RunStep) {
    // A stop or reset for this axis wins over its motion, even one whose start
    // has not reached the line yet (the stop goes first, at emergency
    // priority): not started at all, or stopped at the first poll after the
    // start. (A hold suspends it; HOLD off resumes it.)
    if (run.stop_requested) return stopped_first(cmd.op);
    wait.cancel = [&run] { return run.stop_requested.load(); };
  }
  switch (cmd.op) {
    case Op::Serial:
      act.set_serial_mode(cmd.on);
      return done_result(cmd.op,
                         cmd.on ? "serial input mode (Y30 = 1)" : "parallel input mode (Y30 = 0)");
    case Op::Servo:
      cmd.on ? act.servo_on(kClock.now() + std::chrono::seconds(5))
             : act.servo_off(kClock.now() + std::chrono::seconds(5));
      return done_result(cmd.op, cmd.on ? "servo on (SVRE = 1)" : "servo off (SVRE = 0)");
    case Op::Home:
      return move_result(cmd.op, act.home(deadline, wait), run.stopped_by_other);
    case Op::Move:
      return move_result(cmd.op, act.move(cmd.move, deadline, wait), run.stopped_by_other);
    case Op::RunStep:
      return move_result(cmd.op, act.run_step(*cmd.step, deadline, wait), run.stopped_by_other);
    case Op::Jog: {
      const TimePoint until =
          cmd.jog_duration > Duration{} ? kClock.now() + cmd.jog_duration : TimePoint::max();
      wait.cancel = [&run] {
        return run.cancel.load() || run.stop_requested.load() || run.lease_expired(kClock.now()) ||
               run.tie_closed();
      };
      const auto r = act.jog(cmd.jog_plus, until, kClock.now() + std::chrono::hours(24), wait);
      return jog_result(r, run.lease_expired(kClock.now()), run.tie_closed());
    }
    case Op::Hold:
      if (cmd.on) return judged(cmd.op, act.stop(client::StopKind::Hold, stop_policy(axis)));
      act.hold(false);
      return done_result(cmd.op, "HOLD = 0: the operation resumes");
    case Op::Stop:
      return judged(cmd.op, act.stop(client::StopKind::Stop, stop_policy(axis)));
    case Op::Reset:
      return reset_result(act.reset_alarms(), axis.config->alarm_polarity);
    case Op::StepRead:
      if (cmd.step) return step_read_result(*cmd.step, c.read_step(*cmd.step));
      return table_result(client::backup_steps(c));
    case Op::StepWrite:
      return step_write(c, *cmd.step, cmd.fields);
    case Op::JogStop:
      break;
  }
  return refusal(400, "nothing to do");
}

}  // namespace lec6::serve
