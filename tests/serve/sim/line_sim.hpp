#pragma once
// A deterministic simulation of a line of lec serve (issue 31): the real
// scheduler and emergency lane, the real Modbus TCP gateway rule (decide())
// and the twin's controllers (sim::Controller, the model lec sim serves),
// on a virtual clock, in a plant drawn from a seed: 1-8 controllers, some
// dead, noisy or flapping; PLC output images every 10-100 ms in every
// encoding (FC05, FC0F, FC10 to D90C1); SCADA floods, some through a
// listener that answers reads from the cache; an HMI that opens a connection
// per read; masters that hang up; operators' stops at random moments and
// jogs (each an operation of its own); a shutdown now and then.
//
// Invariants checked on every run (a violation names its seed; the run
// replays exactly from it, with a trace):
//   1. every stop to an answering controller is on the wire within the
//      emergency lane's bound (line/emergency_lane.hpp);
//   2. an accepted stop is never cancelled, and fails with ShuttingDown only
//      once the line has closed;
//   3. every job is answered exactly once (none lost, none twice);
//   4. no job waits without bound: clients' commands take turns by
//      source (line/command_turns.hpp): each source's in the order they
//      came, no source goes twice while another's command waits, and the
//      source that goes is the one served least recently (one that comes
//      in, or back, goes after those already waiting). A command answered
//      from the cache when its turn came, cancelled or moved into the
//      emergency lane waits no more, and a resend is judged by none of this
//      (turns_check.hpp); every job is answered by the line's close;
//   5. a HOLD the line answered as done holds the twin's axis: at rest within
//      its deceleration time, unless a later write released it;
//   6. a write that starts motion, queued before a hard stop to its
//      controller, never reaches the wire after that stop (scheduler.cpp:
//      a stop supersedes it);
//   7. no answer says success where the twin disagrees: each coil of a
//      controller that hears only what it answers holds, at the end, what
//      the last write answered done set it to;
//   8. a read answered from the cache (at its submit, or when its turn
//      came) is no older than its max_cache_age, nor than what its
//      connection already saw; the scheduler's count of cache hits is the
//      clients' count of answers from the cache;
//   9. the scheduler's memory of turns stays bounded however many sources
//      come and go: once a command is queued, it knows at most 64 sources
//      more than it has commands queued (CommandTurns::forget_idle).
//
// What it does not simulate yet: lec serve's operations (moves, judged
// stops: they block on threads of their own; a jog is only its writes, under
// a source of its own), the HTTP/MQTT front-ends, and the Line that drives
// the scheduler on its thread (this file's loop stands for it); they are
// tested through the twin and real sockets (tests/serve/ops/
// operations_stop_test.cpp, tests/serve/line/line_test.cpp,
// tests/integration/).

#include <cstdint>
#include <string>
#include <vector>

namespace lec6::serve::sim_testing {

struct SimRun {
  uint64_t seed = 0;
  std::vector<std::string> violations;  // empty: every invariant held
  std::vector<double> stop_wait_ms;     // submit -> on the wire, stops to answering controllers
  std::vector<double> operator_stop_wait_ms;  // of those, the operators' hard stops (RESET, HOLD)
  std::string plant;                          // what the seed drew, in words
  std::string trace;                          // with `trace`: every event, one per line
  uint64_t hash = 0;                          // of every event: equal runs, equal hashes
  std::size_t jobs = 0, stops = 0, exchanges = 0;
  // Paths of the command turns the plants must reach (LineSim's test), as
  // the scheduler took them: reads answered from the cache at their submit,
  // and when their turn came (queued first: CommandTurns never served them);
  // the scheduler's own count of cache hits (both); the submits at which it
  // forgot idle sources (Scheduler::command_sources fell); the jogs'
  // operations, each a source of its own, that reached the wire.
  std::size_t cache_at_submit = 0, cache_at_turn = 0;
  uint64_t cache_hits = 0;
  std::size_t forgets = 0, jog_sources = 0;
};

SimRun run_line_sim(uint64_t seed, bool trace = false);

}  // namespace lec6::serve::sim_testing
