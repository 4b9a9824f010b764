#pragma once
// Runs a Cycle on controllers: the I/O around the Engine (engine.hpp).
// One thread, one Client per axis (axes on one line share its Master); all
// on one clock: on the in-process twin with a VirtualClock the cycle runs in
// simulated time (waits jump the clock), on a line in real time.
//
//   cycle::Runner run(cycle, {{"x", &client_x}, {"z", &client_z}});
//   cycle::CycleReport r = run.run();
//
// For every step: read every axis for the interlocks (flags and state before
// a step that moves, the flags before a dwell: Engine::next_needs), start
// every activity of the step back to back (a group's moves one after the
// other, one write burst each), then poll the unfinished ones round robin
// (flags, then state) until each has ended. An outcome that aborts ends the
// cycle at once: every axis of the cycle is stopped (a RESET pulse judged by
// the axis, client/stop.hpp) and the report says where each stood. A stop
// request (RunOptions::stop_requested, polled between transactions) does the
// same. Attacked by tests/cycle/runner_test.cpp on the twin.
//
// Thread safety: one thread; the Clients must outlive the Runner.

#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "lec6/client/client.hpp"
#include "lec6/client/stop.hpp"
#include "lec6/cycle/engine.hpp"

namespace lec6::cycle {

// One axis's part of a step, in time from the cycle's start.
struct AxisSpan {
  std::string axis;  // empty for a dwell
  std::string what;  // the step's text
  Duration start{};
  Duration end{};
  Outcome outcome = Outcome::Done;
  std::string detail;
  int32_t position_001mm = 0;  // at the end
  // A move's or push's end on the controller's side, from its polls: BUSY
  // fell after `busy_fell_after` (the last poll that saw it high) and by
  // `busy_fell_by` (the first that saw it low). Unset when no poll showed it.
  std::optional<Duration> busy_fell_after;
  std::optional<Duration> busy_fell_by;
  bool motion = false;  // a move, push or stored step (not a wait or a dwell)
};

struct StepReport {
  std::string path;  // "3", "4.2 (2/5)", "reject.1"
  std::string text;
  Duration start{};
  Duration end{};
  std::vector<AxisSpan> axes;
  std::string decision;  // "continue", "branch reject", "abort", "stopped"
};

// Where an axis stood when a cycle was stopped or aborted.
struct AxisStand {
  std::string axis;
  bool stopped = false;   // a read showed it at rest after the stop
  bool answered = false;  // a read came back: position_001mm is where it stood
  int32_t position_001mm = 0;
  std::string how;  // client::StopReport::describe()
};

// What one line carried during the cycle (LinkStats over the run).
struct LineUse {
  std::string line;  // Master::describe()
  std::vector<std::string> axes;
  uint64_t transactions = 0;
  uint64_t timeouts = 0;
  Duration busy{};  // the line held by exchanges; 0 where not known (Modbus TCP)
};

struct CycleReport {
  bool completed = false;
  std::string ended;  // Finished::reason
  Duration cycle_time{};
  unsigned iterations = 0;  // passes of the whole cycle begun
  std::vector<StepReport> steps;
  std::vector<AxisStand> stood;  // every axis, when the cycle was stopped or aborted
  std::vector<LineUse> lines;    // each line of the cycle, in the order of its first axis
};

// Moments of a step, for a caller that acts on the twin (fault injection):
// Before: its interlocks held, nothing written for it yet; Started: its
// starts were sent, its polls not begun; Ended: it ended (the report made).
enum class StepMoment { Before, Started, Ended };

struct RunOptions {
  std::function<bool()> stop_requested;  // polled between transactions
  // Whether a failed exchange was the stop's doing, not the line's (lec
  // serve shutting down fails every exchange that is not a stop): then the
  // cycle ends "stopped by request", not "line fault". Unset (lec cycle
  // run): a failed exchange is a line fault. Must not throw.
  std::function<bool()> failure_is_stop;
  client::StopPolicy stop_policy{};
  // Each step as it ends (a live printout).
  std::function<void(const StepReport&)> on_step;
  // Each step's moments: `step` the Cycle's step (a group, not its
  // members), `path` as in StepReport ("6 (2/2)"). Must not throw (what it
  // does goes on between the runner's transactions).
  std::function<void(const Step& step, const std::string& path, StepMoment)> at_step;
};

class Runner {
 public:
  // `clients`: the Client of every axis of the cycle, by axis name.
  Runner(const Cycle& cycle, std::map<std::string, client::Client*> clients,
         RunOptions options = {});
  ~Runner();
  Runner(const Runner&) = delete;
  Runner& operator=(const Runner&) = delete;

  CycleReport run();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace lec6::cycle
