#include "cycles/cycle_service.hpp"

#include <fmt/format.h>

#include <atomic>

#include "cycles/cycle_run.hpp"
#include "line/line.hpp"
#include "ops/commands.hpp"
#include "ops/op_results.hpp"

namespace lec6::serve {

using nlohmann::json;

namespace {
const SteadyClock kCycleClock;
}  // namespace

struct CycleService::State {
  std::shared_ptr<const ServedCycle> served;
  std::map<std::string, AxisRef> axes;  // lec serve's axis of each of the cycle's axes
  std::vector<AxisRef> claimed;         // the same, in the cycle's order
  // Under CycleService::mutex_:
  bool running = false;
  std::string source;
  TimePoint since{};
  std::optional<json> last;  // the last run's summary
  std::vector<std::function<void(const OpResult&)>> on_end;
  std::atomic<bool> stop_asked{false};
};

CycleService::CycleService(const AxisDirectory& directory, Operations& ops,
                           std::vector<std::shared_ptr<const ServedCycle>> cycles, Log log)
    : directory_(directory), ops_(ops), log_(std::move(log)) {
  for (auto& served : cycles) {
    auto s = std::make_shared<State>();
    for (const cycle::Axis& a : served->cycle.axes) {
      const ServedCycle::Axis& m = served->axes.at(a.name);
      const AxisRef* ref = directory_.axis(m.serve_name);
      if (!ref || ref->id != m.id || !ref->line_config || ref->line_config->name != m.line) {
        throw InvalidArgument(fmt::format("cycle {}: axis {} ({} ID {} on {}) is not an axis here",
                                          served->name(), a.name, m.serve_name, m.id, m.line));
      }
      s->axes.emplace(a.name, *ref);
      s->claimed.push_back(*ref);
    }
    s->served = std::move(served);
    states_.emplace(s->served->name(), std::move(s));
  }
}

json CycleService::state_json(const State& s) const {
  const cycle::Cycle& c = s.served->cycle;
  json axes = json::array();
  for (const cycle::Axis& a : c.axes) {
    const AxisRef& ref = s.axes.at(a.name);
    axes.push_back({{"axis", a.name},
                    {"serve_axis", ref.name},
                    {"line", ref.line_config->name},
                    {"id", ref.id}});
  }
  json out{{"name", c.name},
           {"file", s.served->file.string()},
           {"axes", axes},
           {"steps", c.steps.size()},
           {"repeat", c.repeat},
           {"running", s.running},
           {"last", s.last ? *s.last : json(nullptr)}};
  if (s.running) {
    out["source"] = s.source;
    out["running_s"] = to_seconds(kCycleClock.now() - s.since);
  }
  return out;
}

json CycleService::list() const {
  std::lock_guard lock(mutex_);
  json out = json::array();
  for (const auto& [name, s] : states_) out.push_back(state_json(*s));
  return out;
}

std::optional<json> CycleService::describe(std::string_view name) const {
  std::lock_guard lock(mutex_);
  const auto it = states_.find(name);
  if (it == states_.end()) return std::nullopt;
  return state_json(*it->second);
}

namespace {

OpResult unknown_cycle(std::string_view name) {
  return refusal(404, fmt::format("no cycle called '{}' (GET /api/cycles lists them)", name));
}

// What GET /api/cycles keeps of a run: its end, not its steps.
json summary_of(const OpResult& r, const std::string& source) {
  json s{{"status", r.status}, {"source", source}};
  for (const char* key : {"completed", "ended", "cycle_time_s", "passes", "stood", "error"}) {
    if (r.body.contains(key)) s[key] = r.body[key];
  }
  return s;
}

}  // namespace

void CycleService::run(std::string_view name, std::string source,
                       std::function<void(OpResult)> done) {
  std::shared_ptr<State> s;
  std::optional<OpResult> refused;  // answered once the lock is let go
  {
    std::lock_guard lock(mutex_);
    const auto it = states_.find(name);
    if (it == states_.end()) {
      refused = unknown_cycle(name);
    } else if (it->second->running) {
      const State& r = *it->second;
      refused =
          refusal(409, fmt::format("cycle {} is running: started {:.1f} s ago by {}; stop "
                                   "it first (POST /api/cycles/{}/stop)",
                                   name, to_seconds(kCycleClock.now() - r.since), r.source, name));
    } else {
      s = it->second;
      s->running = true;
      s->source = source;
      s->since = kCycleClock.now();
      s->stop_asked = false;
    }
  }
  if (refused) return done(std::move(*refused));
  auto started = std::make_shared<std::atomic<bool>>(false);
  auto work = [s, started](const Operations::Claim& claim) {
    *started = true;
    return run_served_cycle(*s->served, s->axes, claim, [s] { return s->stop_asked.load(); });
  };
  auto ended = [this, s, started, source, done = std::move(done)](OpResult r) {
    std::vector<std::function<void(const OpResult&)>> waiting;
    {
      std::lock_guard lock(mutex_);
      s->running = false;
      if (*started) s->last = summary_of(r, source);
      waiting.swap(s->on_end);
    }
    if (*started) {
      log_(r.status == 200 ? LogLevel::Info : LogLevel::Warning,
           fmt::format("cycle {} by {}: {}", s->served->name(), source,
                       r.body.value("ended", r.body.value("error", "ended"))));
    }
    for (auto& w : waiting) w(r);
    done(std::move(r));
  };
  ops_.run_claimed(s->claimed, "cycle " + s->served->name(), std::move(source), std::move(work),
                   std::move(ended));
}

void CycleService::stop(std::string_view name, std::string source,
                        std::function<void(OpResult)> done) {
  std::shared_ptr<State> s;
  // Each axis's stop result, and the cycle's end: answered when both came.
  struct Pending {
    std::mutex mutex;
    json stops = json::object();
    std::size_t waiting = 0;
    std::optional<OpResult> report;
    std::function<void(OpResult)> done;
    void answer_if_complete() {
      if (waiting != 0 || !report || !done) return;
      OpResult r = std::move(*report);
      // The stop's own answer: 200 when every axis was seen stopped.
      bool all = true;
      for (const auto& [axis, body] : stops.items()) all = all && body.value("stopped", false);
      r.status = all ? 200 : 502;
      r.body["stops"] = stops;
      auto d = std::move(done);
      done = nullptr;
      d(std::move(r));
    }
  };
  auto pending = std::make_shared<Pending>();
  pending->done = std::move(done);
  std::optional<OpResult> refused;  // answered once the lock is let go
  {
    std::lock_guard lock(mutex_);
    const auto it = states_.find(name);
    if (it == states_.end()) {
      refused = unknown_cycle(name);
    } else if (!it->second->running) {
      refused = refusal(409, fmt::format("cycle {} is not running", name));
    } else {
      s = it->second;
    }
    if (s) s->stop_asked = true;
    if (s) {
      pending->waiting = s->claimed.size();
      s->on_end.push_back([pending](const OpResult& r) {
        std::lock_guard lock(pending->mutex);
        pending->report = r;
        pending->answer_if_complete();
      });
    }
  }
  if (refused) return pending->done(std::move(*refused));
  log_(LogLevel::Info, fmt::format("stop of cycle {} by {}", name, source));
  // The stop rule of every channel (operations.hpp): each axis's stop goes at
  // Emergency, judged by the axis; the cycle ends on the first.
  for (const AxisRef& axis : s->claimed) {
    Command cmd;
    cmd.op = Op::Stop;
    ops_.run(axis, cmd, source, [pending, name = axis.name](OpResult r) {
      std::lock_guard lock(pending->mutex);
      pending->stops[name] = r.body;
      --pending->waiting;
      pending->answer_if_complete();
    });
  }
}

}  // namespace lec6::serve
