#include "cli/twin_faults.hpp"

#include <fmt/format.h>

#include "lec6/cycle/cycle_file.hpp"
#include "lec6/sim/bus.hpp"

namespace lec6::cli {

namespace {

// The push of `axis` in a step (the step, or a member of its group).
const cycle::Step* push_of(const cycle::Step& s, const std::string& axis) {
  if (s.kind == cycle::Step::Kind::Push && s.axis == axis) return &s;
  for (const auto& m : s.steps) {
    if (m.kind == cycle::Step::Kind::Push && m.axis == axis) return &m;
  }
  return nullptr;
}

}  // namespace

TwinFaults::TwinFaults(const cycle::Cycle& cycle, const std::vector<cycle::Fault>& faults,
                       CycleLines& lines)
    : lines_(lines) {
  for (const auto& f : faults) {
    Armed a;
    a.fault = f;
    a.step = cycle::find_step(cycle, f.step);  // the file's rules made sure it is there
    a.id = cycle.axis(f.axis)->id;
    a.outcome = {f.text, {}, false, "not injected: the step did not run that often"};
    armed_.push_back(std::move(a));
  }
}

sim::Controller* TwinFaults::twin(const Armed& a) {
  sim::Bus* bus = lines_.twin_bus(a.fault.axis);
  return bus ? bus->find(a.id) : nullptr;
}

void TwinFaults::at_step(const cycle::Step& step, const std::string& path,
                         cycle::StepMoment moment) {
  if (moment == cycle::StepMoment::Before) ++runs_[&step];
  for (auto& a : armed_) {
    if (a.away_mm) put_back(a);
    if (a.step != &step || a.done) {
      if (a.step == &step && moment == cycle::StepMoment::Ended && a.outcome.step == path) {
        a.step_ended = true;
        if (a.away_mm) put_back(a);
      }
      continue;
    }
    if (runs_[&step] != a.fault.pass) continue;
    const bool before = a.fault.kind == cycle::Fault::Kind::PushMiss;
    if (moment == (before ? cycle::StepMoment::Before : cycle::StepMoment::Started)) {
      strike(a, step, path);
    } else if (moment == cycle::StepMoment::Ended) {  // refused or aborted before its starts
      a.done = true;
      a.outcome.step = path;
      a.outcome.what = "not injected: the step ended before its starts were sent";
      news_.push_back(fmt::format("fault at step {}: {} ({})", path, a.fault.text, a.outcome.what));
    }
  }
}

void TwinFaults::put_back(Armed& a) {
  if (!a.step_ended) return;
  sim::Controller* c = twin(a);
  if (!c) return;
  const TimePoint now = lines_.clock().now();
  const double at = c->physical(now).position;
  if (a.pushed_from_above ? at <= *a.away_mm : at >= *a.away_mm) return;  // still past it
  try {
    c->set_workpiece(a.away_mm, now);
    a.away_mm.reset();
  } catch (const Error&) {  // moving: at the next step's moment
  }
}

void TwinFaults::strike(Armed& a, const cycle::Step& step, const std::string& path) {
  a.done = true;
  a.outcome.step = path;
  a.outcome.injected = true;
  a.outcome.what = "injected";
  sim::Bus* bus = lines_.twin_bus(a.fault.axis);
  sim::Controller* c = twin(a);
  if (!c) {
    a.outcome.injected = false;
    a.outcome.what = "not injected: the axis is not on a twin";
  } else {
    const TimePoint now = lines_.clock().now();
    try {
      switch (a.fault.kind) {
        case cycle::Fault::Kind::PushMiss: {
          const std::optional<double> was = c->config().workpiece_mm;
          c->set_workpiece(std::nullopt, now);
          if (const cycle::Step* push = push_of(step, a.fault.axis); was && push) {
            // Which side the push comes from, by the twin's own rule: it
            // presses on from its start away from where the carriage stands.
            const double here = c->physical(now).position;
            const double offset = here - c->position_mm(now);
            const double to = static_cast<double>(push->move.position_001mm.value_or(0)) / 100.0;
            const double start = push->move.relative ? here + to : to + offset;
            a.pushed_from_above = start < here - 1e-3;
            a.away_mm = was;
          }
          break;
        }
        case cycle::Fault::Kind::Alarm:
          c->inject_alarm(a.fault.alarm_code, now);
          break;
        case cycle::Fault::Kind::CutOff:
          bus->set_cut_off(a.id, true);
          break;
      }
    } catch (const Error& e) {
      a.outcome.injected = false;
      a.outcome.what = fmt::format("not injected: {}", e.what());
    }
  }
  news_.push_back(fmt::format("fault at step {}: {} ({})", path, a.fault.text, a.outcome.what));
}

std::vector<InjectedFault> TwinFaults::report() const {
  std::vector<InjectedFault> out;
  for (const auto& a : armed_) out.push_back(a.outcome);
  return out;
}

std::vector<std::string> TwinFaults::take_news() {
  return std::exchange(news_, {});
}

}  // namespace lec6::cli
