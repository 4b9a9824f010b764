#pragma once
// The cycle engine, sans-I/O: it walks a Cycle's steps (repeats, branches,
// parallel groups), checks the interlocks against the axes' latest state
// before every step that moves, and decides from each step's outcomes
// where the cycle goes. It reads no clock and sends nothing: the Runner
// (runner.hpp) feeds it the axes' state and the outcomes, and the Watch
// (watch.hpp) judges each activity from polls and time points.
//
//   Engine e(cycle);
//   for (;;) {
//     auto next = e.next(read_every_axis());
//     if (auto* end = std::get_if<Finished>(&next)) break;        // completed, refused, aborted
//     auto& batch = std::get<Batch>(next);                         // one step or a group
//     e.finished(run(batch));                                      // one result per activity
//   }
//
// Rules (docs/cycles.md, "Safety"), each attacked by tests/cycle/engine_test.cpp:
//  - a user interlock is also checked at every poll while its axis moves
//    (Runner): broken, every axis is stopped and the cycle ends;
//  - a step that moves runs only when every axis of the cycle answers with
//    no alarm and no ESTOP, each axis it moves is homed (SETON) with its
//    servo ready (SVRE), its target lies within its soft limits, and every
//    user interlock naming it holds; otherwise the cycle ends, refused,
//    before anything is written for that step;
//  - an outcome goes where the step's `on` says; without a word: reached,
//    pushed and done continue, anything else aborts;
//  - a group ends when all its members have; when several members branch,
//    the first (in file order) is taken; one abort aborts.
//
// Thread safety: one thread at a time. The Engine keeps a reference to the
// Cycle, which must outlive it.

#include <map>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "lec6/cycle/cycle.hpp"
#include "lec6/lec/flags.hpp"
#include "lec6/lec/state_data.hpp"

namespace lec6::cycle {

struct AxisState {
  lec::StatusFlags flags;
  lec::StateData state;
  bool answered = true;  // false: the axis did not answer the last read
};
using AxisStates = std::map<std::string, AxisState>;

// One leaf step of a batch: a move, push, stored step, wait or dwell.
struct Activity {
  const Step* step = nullptr;
};

// What to run now: one step, or the members of a parallel group.
struct Batch {
  std::string path;  // "3", "4.2 (2/5)", "reject.1": where in the file
  const Step* step = nullptr;
  std::vector<Activity> activities;
};

struct Finished {
  bool completed = false;
  std::string reason;  // "completed", "interlock: ...", "aborted: ...", "stopped: ..."
};

struct ActivityResult {
  Outcome outcome = Outcome::Done;
  std::string detail;  // "reached 120.00 mm (INP...) in 0.41 s"
};

// The first interlock that does not hold for running `step` (a leaf or a
// group), in the user's terms; nullopt when all hold. Pure.
std::optional<std::string> interlock_violation(const Cycle& cycle, const Step& step,
                                               const AxisStates& axes);

// The first user interlock naming `moving` ("z below 45 mm before x
// moves") that does not hold. The Runner also checks it at every poll while
// `moving` moves: an interlock broken during a step stops every axis.
std::optional<std::string> user_interlock_violation(const Cycle& cycle, const std::string& moving,
                                                    const AxisStates& axes);

// Where `outcome` of `step` sends the cycle (the step's `on`, else the defaults).
Target target_of(const Step& step, Outcome outcome);

class Engine {
 public:
  explicit Engine(const Cycle& cycle);

  // The next batch, or how the cycle ended (then always that).
  std::variant<Batch, Finished> next(const AxisStates& axes);
  // What next() will judge of the axes, so that the Runner reads no more:
  //  - FlagsAndState before a step that moves, a wait, a group, a repeat's
  //    `until` (and the Runner reads so before the cycle's first step);
  //  - Flags before a dwell alone: it runs only when every axis answers with
  //    no alarm and no ESTOP, which the flags say (one read per axis, not two);
  //  - Nothing at the cycle's end (no decision is left). Pure.
  enum class AxesNeeded { Nothing, Flags, FlagsAndState };
  AxesNeeded next_needs() const;
  // The outcome of every activity of the last batch, in order. Returns the
  // decision in words ("continue", "branch reject", "abort").
  std::string finished(const std::vector<ActivityResult>& results);
  // Ends the cycle from outside (a stop request, a line fault).
  void end(std::string reason);

  unsigned iteration() const noexcept { return iteration_; }  // 1-based, of cycle.repeat
  const std::optional<Finished>& result() const noexcept { return finished_; }

 private:
  struct Frame {
    const std::vector<Step>* steps;
    std::size_t index = 0;
    unsigned remaining = 1;  // passes still to run, this one included
    unsigned times = 1;
    std::string prefix;            // "" (the cycle), "4." (a repeat), "reject." (a branch)
    const Step* repeat = nullptr;  // the repeat step it runs (its `until`)
    std::string path;              // the repeat's own path, for messages
  };
  std::string path_of(const Frame& f) const;
  // The walk of next() (one rule for both): moves `stack` to the step to
  // run next and returns it, or nullptr at the end of the cycle or when a
  // repeat's last pass did not meet its `until` (then `*failed` says so).
  // `axes` null: a probe (next_needs, on a copy of the frames), where a
  // repeat's `until` on the way sets `*until` and ends the walk.
  const Step* walk(std::vector<Frame>& stack, unsigned& iteration, const AxisStates* axes,
                   std::optional<Finished>* failed, bool* until) const;

  const Cycle& cycle_;
  std::vector<Frame> stack_;
  std::optional<Batch> current_;
  std::optional<Finished> finished_;
  unsigned iteration_ = 1;
};

}  // namespace lec6::cycle
