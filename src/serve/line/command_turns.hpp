#pragma once
// Client commands take turns by who sent them (the scheduler's Command class).
//
// First in first out across clients let one client that keeps the line full
// hold everyone else's commands: under twenty SCADA connections with 8 reads
// each in flight, an operator's move from the HMI waited 8-15 s (issue 31,
// bench/stop_bench.py --loads plant). Now each source (Job::source: a Modbus
// TCP connection, one HTTP/MQTT/CLI operation) keeps its own order, and the
// sources take turns: the next command is the oldest of the source served
// least recently. A source that comes in (or back) takes its turn after the
// sources already waiting, so a new connection per request neither jumps the
// queue nor starves the connections that stay (one request at a time). A command waits at most one
// transaction per other source with commands queued (plus a retry of the one
// before it). Stops are not here: they have their own lane (emergency_lane.hpp).
//
// Sans-I/O, no clock: the scheduler calls it with its Command queue.

#include <cstdint>
#include <deque>
#include <unordered_map>

#include "line/job.hpp"

namespace lec6::serve {

class CommandTurns {
 public:
  // A job of `source` was queued (the scheduler's submit); `waiting`: the
  // source already has a job in the queue. One that had none comes in (or
  // back) now: whatever turn it held when its last job left the queue
  // (answered from the cache, cancelled, superseded by a stop, failed) is
  // not kept, so it never goes ahead of those already waiting.
  void queued(JobSource source, bool waiting);
  // The job to take next from `q` (not empty): a retry at the front first
  // (it keeps its place), else the oldest job of the source whose turn it is.
  std::deque<Queued>::iterator pick(std::deque<Queued>& q);
  // `source`'s job was taken for the wire; `more`: it has others queued.
  void served(JobSource source, bool more);
  // Sources with nothing queued any more (their jobs cancelled, failed or
  // superseded) are forgotten: when they come back, they wait their turn.
  // The scheduler calls it when more are known than `q` could hold (a
  // client that opens a connection per request cannot grow it without bound).
  void forget_idle(const std::deque<Queued>& q);
  std::size_t known() const noexcept { return turn_of_.size(); }

 private:
  // The turn each source waits for: the count of dispatches when it was last
  // served, or when it came in. The smallest goes first.
  std::unordered_map<JobSource, uint64_t> turn_of_;
  uint64_t served_ = 0;
};

}  // namespace lec6::serve
