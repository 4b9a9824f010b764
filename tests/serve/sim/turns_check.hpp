#pragma once
// Invariant 4 of the line simulation (line_sim.hpp): clients' commands take
// turns by source (line/command_turns.hpp). A source's commands reach the
// wire in the order they came; while one source's command waits, no other
// source goes twice; and the one that goes is the source served least
// recently: one that comes in (or back) goes after the sources already
// waiting, and on a tie (it came in just as the other was served) the older
// command goes first.
//
// A command waits from its submit until it leaves the Command queue: on the
// wire, or without it (answered from the cache when its turn came,
// cancelled, refused, superseded, moved into the emergency lane by a stop).
// One that left without the wire had no turn: its source's turn is as it
// was, and a source left with nothing queued comes back as one that comes
// in. A source the scheduler forgot (CommandTurns::forget_idle) had nothing
// queued: it comes back the same way. A command whose exchange was lost
// waits for its resend: the rules above do not judge it nor its resend (it
// keeps its place), but the resend moves its source's turn, as any
// dispatch does.
//
// The line's driver tells it what left before each exchange (the
// completions next() collected): the check knows exactly what waits.

#include <cstddef>
#include <cstdint>
#include <map>
#include <string>

#include "line/job.hpp"

namespace lec6::serve::sim_testing {

class TurnsCheck {
 public:
  // Job `key` (keys grow in the order of the submits) was queued at
  // Priority::Command by `source`, to controller `id`.
  void queued(std::size_t key, JobSource source, uint8_t id);
  // It left the queue for good: answered (by the wire or the cache), failed,
  // cancelled, superseded, or moved into the emergency lane.
  void left(std::size_t key);
  // Its exchange was lost: a resend may follow.
  void lost(std::size_t key);
  // Its exchange begins. Returns what it broke ("": nothing).
  std::string on_wire(std::size_t key);

 private:
  struct Waiting {
    JobSource source = 0;
    uint8_t id = 0;
    std::size_t submitted = 0;  // sent_ at its submit
    bool resending = false;     // its last exchange was lost
  };
  std::string broken_by(std::size_t key, const Waiting& t) const;
  uint64_t turn_of(JobSource source) const;

  std::map<std::size_t, Waiting> waiting_;    // by key
  std::map<JobSource, std::size_t> queued_;   // each source's jobs in waiting_
  std::map<JobSource, std::size_t> last_of_;  // each source's last turn, by sent_
  std::size_t sent_ = 0;                      // client commands on the wire (resends not)
  // Each waiting source's turn: the count of dispatches (resends too) when
  // it was last served, or when it came in. The smallest goes first.
  std::map<JobSource, uint64_t> turn_;
  uint64_t dispatches_ = 0;
};

}  // namespace lec6::serve::sim_testing
