// Operations::run_claimed: the motion slots of several axes held by one
// piece of work (a machine cycle, serve/cycles/), under the rules of
// operations.hpp.

#include <fmt/format.h>

#include <system_error>
#include <thread>

#include "ops/op_results.hpp"
#include "ops/operation_slots.hpp"

namespace lec6::serve {

namespace {
const SteadyClock kClaimClock;
}  // namespace

void Operations::run_claimed(const std::vector<AxisRef>& axes, std::string what, std::string source,
                             std::function<OpResult(const Claim&)> work,
                             std::function<void(OpResult)> done) {
  if (axes.empty()) return done(refusal(400, what + ": no axes"));
  std::vector<std::shared_ptr<Running>> runs;
  std::optional<OpResult> refused;
  {
    std::lock_guard lock(mutex_);
    // Every axis checked first: all slots are taken, or none. (`done` is
    // called after the lock is let go: it may ask Operations again.)
    if (shutting_down_) refused = refusal(503, "lec serve is shutting down");
    for (const AxisRef& axis : axes) {
      if (refused) break;
      Slot& slot = slots_[axis.name];
      std::erase_if(slot.stops, [](const auto& w) { return w.expired(); });
      if (slot.motion) {
        const Running& r = *slot.motion;
        refused = refusal(409, fmt::format("axis {} is busy: {} started {:.1f} s ago by {}; stop "
                                           "it first (stop, or jog-stop for a jog)",
                                           axis.name, r.name(),
                                           to_seconds(kClaimClock.now() - r.since), r.source));
      } else if (slot.unsettled && !settled(axis, *slot.unsettled)) {
        refused = unsettled_refusal(axis, *slot.unsettled);
      } else if (!slot.stops.empty()) {
        const auto s = slot.stops.front().lock();
        refused = refusal(409, fmt::format("axis {}: the {} by {} accepted before still runs; "
                                           "nothing was sent: try again once it has ended",
                                           axis.name, s ? s->name() : "stop", s ? s->source : "?"));
      }
    }
    if (!refused) {
      const TimePoint accepted = axes.front().line->clock().now();
      for (const AxisRef& axis : axes) {
        auto run = std::make_shared<Running>();
        run->op = Op::Move;
        run->what = what;
        run->source = source;
        run->since = kClaimClock.now();
        run->accepted = accepted;
        Slot& slot = slots_[axis.name];
        slot.motion = run;
        slot.unsettled.reset();
        runs.push_back(std::move(run));
      }
    }
  }
  if (refused) return done(std::move(*refused));
  began_one();
  log_(LogLevel::Info, fmt::format("{} on {} axes by {}", what, axes.size(), source));
  // `done` is kept here until the thread has it: a thread that cannot be
  // made (std::system_error: no resources) frees the slots and says so. (A
  // cycle starts motion: refused, not run on the caller's thread.)
  auto done_once = std::make_shared<std::function<void(OpResult)>>(std::move(done));
  try {
    start_claimed(axes, runs, std::move(work), done_once);
  } catch (const std::exception& e) {  // no thread (system_error), no memory for it
    log_(LogLevel::Warning, fmt::format("{}: not started: {}", what, e.what()));
    {
      std::lock_guard lock(mutex_);
      for (std::size_t i = 0; i < axes.size(); ++i) {
        Slot& slot = slots_[axes[i].name];
        if (slot.motion == runs[i]) slot.motion.reset();
      }
    }
    for (const auto& r : runs) r->ended_promise.set_value();
    ended_one();
    if (*done_once)
      (*done_once)(
          refusal(503, fmt::format("{}: not started ({}); nothing was sent", what, e.what())));
  }
}

void Operations::start_claimed(const std::vector<AxisRef>& axes,
                               const std::vector<std::shared_ptr<Running>>& runs,
                               std::function<OpResult(const Claim&)> work,
                               std::shared_ptr<std::function<void(OpResult)>> done_once) {
  std::thread([this, axes, runs, work = std::move(work), done_once] {
    const auto done = std::move(*done_once);
    Claim claim;
    claim.accepted = runs.front()->accepted;
    // Looked at under the lock a stop is accepted under: one accepted (and
    // dated) before this look is seen by it (cycle_service.hpp). A servo off
    // counts too: it is a stop that does not wait (stop_like).
    auto seen = std::make_shared<bool>(false);
    claim.stopped = [this, &axes, &runs, seen, accepted = claim.accepted] {
      std::lock_guard lock(mutex_);
      if (*seen || shutting_down_) return *seen = true;
      for (std::size_t i = 0; i < axes.size(); ++i) {
        if (runs[i]->stopped_by_other.load()) return *seen = true;
        for (const auto& w : slots_[axes[i].name].stops) {
          const auto s = w.lock();
          if (s && s->accepted >= accepted) return *seen = true;
        }
      }
      return false;
    };
    OpResult result;
    try {
      result = work(claim);
    } catch (...) {
      result = result_of(std::current_exception(), claim.stopped());
    }
    {
      std::lock_guard lock(mutex_);
      for (std::size_t i = 0; i < axes.size(); ++i) {
        Slot& slot = slots_[axes[i].name];
        if (slot.motion != runs[i]) continue;
        slot.motion.reset();
        if (result.status >= 500) {
          slot.unsettled = Unsettled{runs[i]->op, runs[i]->source,
                                     result.body.value("error", result.body.value("ended", "")),
                                     axes[i].line->clock().now(), runs[i]->what};
        }
      }
    }
    for (const auto& r : runs) r->ended_promise.set_value();
    done(std::move(result));
    ended_one();
  }).detach();
}

}  // namespace lec6::serve
