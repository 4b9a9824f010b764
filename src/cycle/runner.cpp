#include "lec6/cycle/runner.hpp"

#include <fmt/format.h>

#include <algorithm>

#include "lec6/client/actuator.hpp"
#include "lec6/cycle/watch.hpp"
#include "lec6/lec/units.hpp"
#include "line_tally.hpp"

namespace lec6::cycle {

namespace {

// How long the line idles at most during a dwell before the stop request is
// looked at again.
constexpr Duration kCycleDwellSlice = std::chrono::milliseconds(50);

struct Live {
  const Step* step = nullptr;
  std::optional<client::PreparedMove> prepared;  // a group's move, its start not yet sent
  std::optional<Watch> watch;
  std::optional<ActivityResult> result;
  AxisSpan span;
};

// How a batch ended: every activity resolved, or cut short (an abort, a stop).
struct BatchEnd {
  std::vector<ActivityResult> results;
  std::optional<std::string> cut;  // the reason the cycle ends now
};

}  // namespace

struct Runner::Impl {
  struct AxisIo {
    client::Client* client = nullptr;
    std::unique_ptr<client::Actuator> actuator;
  };

  Impl(const Cycle& c, std::map<std::string, client::Client*> clients, RunOptions o)
      : cycle(c), options(std::move(o)) {
    for (const auto& a : c.axes) {
      auto it = clients.find(a.name);
      if (it == clients.end() || !it->second) {
        throw InvalidArgument(fmt::format("cycle runner: no client for axis {}", a.name));
      }
      AxisIo io{it->second, std::make_unique<client::Actuator>(*it->second)};
      io.actuator->set_soft_limits(a.soft_limits);
      axes.emplace(a.name, std::move(io));
    }
  }

  const Clock& clock() const { return axes.begin()->second.client->clock(); }
  Duration since_start() const { return clock().now() - t0; }
  bool stop_requested() const { return options.stop_requested && options.stop_requested(); }

  // Reads every axis: its flags, and its state when `need` says so (what the
  // engine's next decision judges: Engine::next_needs).
  AxisStates read_all(Engine::AxesNeeded need = Engine::AxesNeeded::FlagsAndState) {
    if (need == Engine::AxesNeeded::Nothing) return states;
    for (const auto& a : cycle.axes) {
      AxisState& s = states[a.name];
      try {
        auto& c = *axes.at(a.name).client;
        s.flags = c.read_flags();
        if (need == Engine::AxesNeeded::FlagsAndState) s.state = c.read_state();
        s.answered = true;
      } catch (const client::TransportError&) {
        s.answered = false;
      }
    }
    return states;
  }

  // A RESET pulse to every axis first (one write pair each: the axes start
  // decelerating together), then each stop judged by its axis (stop.hpp:
  // the pulse again, reads until at rest, escalation by the policy).
  std::vector<AxisStand> stop_all() {
    for (const auto& a : cycle.axes) {
      try {
        axes.at(a.name).actuator->stop();
      } catch (const Error&) {  // the judged stop below reports what could not be sent
      }
    }
    std::vector<AxisStand> stood;
    for (const auto& a : cycle.axes) {
      try {
        const client::StopReport r =
            axes.at(a.name).actuator->stop(client::StopKind::Stop, options.stop_policy);
        stood.push_back({a.name, r.stopped, r.answered, r.state.position_001mm, r.describe()});
        states[a.name].state = r.state;
      } catch (const client::ControllerException& e) {
        // Refused (a controller in parallel mode refuses RESET over serial):
        // said for this axis; the others' stops still go and are judged.
        stood.push_back({a.name, false, false, 0,
                         fmt::format("the stop was refused by the controller: {}", e.what())});
      }
    }
    return stood;
  }

  // The first half of a move's start (Actuator::prepare): a group prepares
  // every member, then sends the starts back to back (start()).
  void prepare(Live& l) {
    const Step& s = *l.step;
    if (s.kind != Step::Kind::Move && s.kind != Step::Kind::Push) return;
    l.span.start = since_start();
    guarded(l, [&] { l.prepared = axes.at(s.axis).actuator->prepare(s.move); });
  }

  void start(Live& l) {
    const Step& s = *l.step;
    if (!l.prepared) l.span.start = since_start();
    if (s.kind == Step::Kind::Wait || s.kind == Step::Kind::Dwell) {
      l.watch = Watch::timed(s, clock().now());
      return;
    }
    auto& act = *axes.at(s.axis).actuator;
    guarded(l, [&] {
      if (s.kind == Step::Kind::RunStep) {  // never in a group: run to its end here
        client::WaitOptions w;
        w.cancel = [this] { return stop_requested(); };
        const auto r = act.run_step(s.stored_step, act.deadline_in(s.timeout), w);
        l.result = ActivityResult{outcome_of(r.outcome), r.describe()};
        l.span.position_001mm = r.state.position_001mm;
        return;
      }
      const client::StartedMove started = l.prepared ? act.go(*l.prepared) : act.start(s.move);
      l.span.start = started.start.at - t0;
      l.watch = Watch::motion(s, started.start, started.start.at + s.timeout);
    });
  }

  // Runs `f`; what a start can throw becomes the activity's outcome.
  template <typename F>
  void guarded(Live& l, F&& f) {
    try {
      f();
    } catch (const client::InvalidRequest& e) {
      l.result = ActivityResult{Outcome::Refused, e.what()};
    } catch (const client::ControllerException& e) {
      l.result = ActivityResult{Outcome::Refused, e.what()};
    } catch (const client::AlarmError& e) {
      l.result = ActivityResult{Outcome::Alarm, e.what()};
    } catch (const client::DeadlineError& e) {
      l.result = ActivityResult{Outcome::Timeout, e.what()};
    } catch (const client::MoveNotStarted& e) {
      l.result = ActivityResult{Outcome::NotStarted, e.what()};
    } catch (const client::Cancelled& e) {
      l.result = ActivityResult{Outcome::Stopped, e.what()};
    }
  }

  // `round`: the polls of this round by axis; an axis two members watch
  // (a move and a wait on it) is read once per round.
  void poll(Live& l, std::map<std::string, client::Poll>& round) {
    if (l.step->kind == Step::Kind::Dwell) {
      l.result = l.watch->feed_time(clock().now());
      return;
    }
    auto it = round.find(l.step->axis);
    if (it == round.end()) {
      auto& c = *axes.at(l.step->axis).client;
      client::Poll fresh;
      fresh.flags = c.read_flags();
      fresh.at = c.clock().now();
      fresh.state = c.read_state();
      it = round.emplace(l.step->axis, fresh).first;
    }
    const client::Poll& p = it->second;
    states[l.step->axis] = {p.flags, p.state, true};
    l.span.position_001mm = p.state.position_001mm;
    l.result = l.watch->feed(p);
    if (l.result && l.result->outcome == Outcome::Alarm) {
      // The completion rule judged from the flags alone ("no code in the
      // history"): the codes, read now, make the sentence `lec move` says.
      try {
        const auto codes = axes.at(l.step->axis).actuator->active_alarms(p.flags);
        if (const auto& m = l.watch->move_result(); m && !codes.empty()) {
          client::MoveResult with = *m;
          with.alarm_codes = codes;
          l.result->detail = with.describe();
        } else if (!codes.empty()) {
          std::string list;
          for (auto code : codes) list += fmt::format("{}{}", list.empty() ? "" : ", ", code);
          l.result->detail += " (alarm " + list + ")";
        }
      } catch (const Error&) {
      }
    }
  }

  void moment(const Batch& b, StepMoment m) {
    if (options.at_step) options.at_step(*b.step, b.path, m);
  }

  // Where the controller's BUSY fell, from the move's own timeline.
  void note_busy_fall(Live& l) const {
    if (!l.watch || !l.watch->move_result()) return;
    const client::MoveResult& m = *l.watch->move_result();
    const Duration started = m.started_at - t0;
    if (m.timeline.busy_down_after) l.span.busy_fell_after = started + *m.timeline.busy_down_after;
    if (m.timeline.busy_down) l.span.busy_fell_by = started + *m.timeline.busy_down;
  }

  // Their end is when the cut came: the stops after it are the step's, not theirs.
  std::vector<AxisStand> cut(std::vector<Live>& live, const std::string& why) {
    const Duration at = since_start();
    auto stood = stop_all();
    for (auto& l : live) {
      if (l.result) continue;
      l.result = ActivityResult{Outcome::Stopped, why};
      l.span.end = at;
      l.span.outcome = Outcome::Stopped;
      l.span.detail = why;
      if (!l.step->axis.empty()) l.span.position_001mm = states[l.step->axis].state.position_001mm;
    }
    return stood;
  }

  // The user interlocks of every axis still moving, on the latest polls.
  void check_interlocks_during(const Batch& b, std::vector<Live>& live, BatchEnd& end,
                               std::vector<AxisStand>& stood) {
    for (const auto& l : live) {
      if (l.result || !l.step->moves()) continue;
      if (auto why = user_interlock_violation(cycle, l.step->axis, states)) {
        end.cut =
            fmt::format("interlock broken during step {} ({}): {}", b.path, b.step->text, *why);
        stood = cut(live, "stopped: interlock broken: " + *why);
        return;
      }
    }
  }

  BatchEnd run_batch(const Batch& b, StepReport& report, std::vector<AxisStand>& stood) {
    std::vector<Live> live;
    for (const auto& a : b.activities) {
      Live l;
      l.step = a.step;
      l.span.axis = a.step->axis;
      l.span.what = a.step->text;
      l.span.motion = a.step->moves();
      if (!l.step->axis.empty()) l.span.position_001mm = states[l.step->axis].state.position_001mm;
      live.push_back(std::move(l));
    }
    try {
      BatchEnd end = run_live(b, live, stood);
      for (auto& l : live) {
        end.results.push_back(*l.result);
        report.axes.push_back(l.span);
      }
      return end;
    } catch (const client::TransportError& e) {  // the step's members stay in its report
      keep_members(live, report, Outcome::LineFault, e.what());
      throw;
    } catch (const client::ControllerException& e) {  // an exception reply to a poll
      keep_members(live, report, Outcome::Refused, e.what());
      throw;
    }
  }

  // The members of a step cut short by an exception: those still running end
  // now with `outcome`, and every member goes into the step's report.
  void keep_members(std::vector<Live>& live, StepReport& report, Outcome outcome,
                    const std::string& detail) {
    for (auto& l : live) {
      if (!l.result) {
        l.span.end = since_start();
        l.span.outcome = outcome;
        l.span.detail = detail;
      }
      report.axes.push_back(l.span);
    }
  }

  // Starts a batch's members and polls them until each has ended.
  BatchEnd run_live(const Batch& b, std::vector<Live>& live, std::vector<AxisStand>& stood) {
    BatchEnd end;
    moment(b, StepMoment::Before);
    auto settle = [&](Live& l) -> bool {  // true: the cycle ends now
      l.span.end = since_start();
      l.span.outcome = l.result->outcome;
      l.span.detail = l.result->detail;
      note_busy_fall(l);
      if (target_of(*l.step, l.result->outcome).kind != Target::Abort) return false;
      end.cut = fmt::format("aborted at step {} ({}): {}: {}", b.path, l.step->text,
                            outcome_name(l.result->outcome), l.result->detail);
      stood = cut(live, "stopped: the cycle was aborted");
      return true;
    };
    // Every member's checks and direct data first, then the starts back to
    // back: the group's axes start one transaction apart.
    bool cut_short = false;
    if (live.size() > 1) {
      for (auto& l : live) {
        prepare(l);
        if (l.result && settle(l)) {
          cut_short = true;
          break;
        }
      }
    }
    for (auto& l : live) {
      if (cut_short) break;
      if (l.result) continue;  // refused in prepare(), settled there
      start(l);
      if (l.result && settle(l)) break;
    }
    if (!end.cut) moment(b, StepMoment::Started);
    while (!end.cut &&
           std::any_of(live.begin(), live.end(), [](const Live& l) { return !l.result; })) {
      if (stop_requested()) {
        end.cut = fmt::format("stopped by request during step {} ({})", b.path, b.step->text);
        stood = cut(live, "stopped by request");
        break;
      }
      bool polled = false;
      std::optional<TimePoint> wake;
      std::map<std::string, client::Poll> round;
      for (auto& l : live) {
        if (l.result) continue;
        if (l.step->kind != Step::Kind::Dwell) polled = true;
        poll(l, round);
        if (l.result && settle(l)) break;
        if (!l.result && l.watch->wake_at())
          wake = std::min(wake.value_or(TimePoint::max()), *l.watch->wake_at());
      }
      if (!end.cut) check_interlocks_during(b, live, end, stood);
      // A dwell alone: the line idles until it ends, in slices, so that a
      // stop request is still seen within one (a 4 s dwell held Ctrl-C 4 s).
      if (!polled && wake && !end.cut)
        axes.begin()->second.client->idle_until(std::min(*wake, clock().now() + kCycleDwellSlice));
    }
    return end;
  }

  // The cycle ends before its engine did (a line fault, a stop that failed
  // the exchange under way, an exception reply): the step under way is
  // reported with `decision`, every axis is stopped, and where each stood
  // goes into the report.
  void end_early(Engine& engine, CycleReport& report, std::optional<StepReport>& running,
                 const std::string& decision, const std::string& reason) {
    engine.end(reason);
    report.stood = stop_all();  // first: nothing after may leave an axis moving
    if (running) {
      running->end = since_start();
      running->decision = decision;
      report.steps.push_back(*running);
      if (options.on_step) options.on_step(report.steps.back());
    }
  }

  // RunOptions::failure_is_stop, and a stop asked for: a throw is "no".
  // stop_requested() is looked at first, always: the caller may act on a
  // stop seen (lec serve: its reads go at Emergency from then on).
  bool failure_was_stop() const noexcept {
    try {
      const bool stop = stop_requested();
      return stop && options.failure_is_stop && options.failure_is_stop();
    } catch (...) {
      return false;
    }
  }

  CycleReport run() {
    CycleReport report;
    t0 = clock().now();
    for (const auto& a : cycle.axes) lines.add(a.name, axes.at(a.name).client->master());
    Engine engine(cycle);
    bool first = true;  // a Runner may run again: nothing read by the last run counts
    std::optional<StepReport> running;  // the step under way, for a line fault
    try {
      for (;;) {
        if (stop_requested()) {
          report.stood = stop_all();
          engine.end("stopped by request between steps");
          break;
        }
        // Every axis, flags and state, before the first step and every step
        // that moves; its flags before a dwell; nothing at the end.
        AxisStates seen = read_all(first ? Engine::AxesNeeded::FlagsAndState : engine.next_needs());
        first = false;
        // A stop that came during those reads (lec serve shutting down
        // fails them: the next step would be refused as "does not answer").
        if (stop_requested()) {
          report.stood = stop_all();
          engine.end("stopped by request between steps");
          break;
        }
        auto next = engine.next(std::move(seen));
        if (std::holds_alternative<Finished>(next)) break;
        const Batch& b = std::get<Batch>(next);
        running = StepReport{b.path, b.step->text, since_start(), {}, {}, {}};
        StepReport& step = *running;
        const BatchEnd end = run_batch(b, step, report.stood);
        step.end = since_start();
        if (end.cut) {
          engine.end(*end.cut);
          step.decision = stop_requested() ? "stopped" : "abort";
        } else {
          step.decision = engine.finished(end.results);
          if (step.decision == "abort") report.stood = stop_all();
        }
        report.steps.push_back(step);
        running.reset();
        moment(b, StepMoment::Ended);
        if (options.on_step) options.on_step(report.steps.back());
        if (engine.result()) break;
      }
    } catch (const client::TransportError& e) {
      const std::string during =
          running ? fmt::format(" during step {} ({})", running->path, running->text) : "";
      if (failure_was_stop()) {
        // A stop came, and the exchange under way failed with it (lec serve
        // shutting down fails what is not a stop): the stop ended the cycle,
        // not the line. Its axes are stopped and read as for any stop.
        end_early(engine, report, running, "stopped",
                  "stopped by request" + during + "; the exchange under way: " + e.what());
      } else {
        end_early(engine, report, running, "line fault", "line fault" + during + ": " + e.what());
      }
    } catch (const client::ControllerException& e) {
      // An exception reply outside a step's own action (the reads between
      // steps): the cycle cannot go on, and says where its axes stood.
      const std::string during =
          running ? fmt::format(" during step {} ({})", running->path, running->text) : "";
      end_early(engine, report, running, "abort", "aborted" + during + ": " + e.what());
    } catch (...) {
      // Anything else (a caller's stop_requested or on_step that threw) ends
      // the cycle too, never with its axes left moving: every axis is
      // stopped, then the error goes on.
      try {
        stop_all();
      } catch (...) {
      }
      throw;
    }
    report.completed = engine.result() && engine.result()->completed;
    report.ended = engine.result() ? engine.result()->reason : "completed";
    report.cycle_time = since_start();
    report.iterations = engine.iteration();
    report.lines = lines.since_added();
    return report;
  }

  const Cycle& cycle;
  RunOptions options;
  std::map<std::string, AxisIo> axes;
  AxisStates states;
  TimePoint t0{};
  detail::LineTally lines;
};

Runner::Runner(const Cycle& cycle, std::map<std::string, client::Client*> clients,
               RunOptions options)
    : impl_(std::make_unique<Impl>(cycle, std::move(clients), std::move(options))) {}

Runner::~Runner() = default;

CycleReport Runner::run() {
  return impl_->run();
}

}  // namespace lec6::cycle
