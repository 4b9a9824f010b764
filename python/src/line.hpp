#pragma once
// One bus shared by Python threads: lec6::client::SharedMaster (a ticket lock:
// each exchange takes the line in turn, first come first served, so a move
// polling in one thread and status() calls in another interleave transaction
// by transaction instead of one starving the other).

#include "lec6/client/shared_master.hpp"
#include "lec6/clock.hpp"

namespace lec6::python {

using SharedLine = client::SharedMaster;

// The clock of every bus: steady, and valid after the bus is closed.
inline const SteadyClock& line_clock() {
  static const SteadyClock clock;
  return clock;
}

}  // namespace lec6::python
