#pragma once
// Sends a capture's queries again through a Master (issue 24, `lec replay`),
// keeping their order and, with ReplayTiming::AsCaptured, their spacing: each
// query ends at its captured offset from the first one (it starts one wire
// time earlier; later only when the previous exchange is not over yet), so
// the controller acts on it at the captured instant. Every reply (or its absence) is kept
// with its times, for compare() (replay.hpp). The Master decides where the
// queries go (a port, the in-process twin on a virtual clock).
//
// Thread safety: uses the Master from the calling thread only.

#include <span>
#include <vector>

#include "lec6/client/master.hpp"
#include "lec6/twin/replay.hpp"

namespace lec6::twin {

// The replayed exchanges, one per captured exchange. Times are µs from the
// replay's first query. A query that does not decode as a request, and a
// broadcast, are not sent (reply: none).
std::vector<Exchange> run_replay(client::Master& master, std::span<const Exchange> captured,
                                 ReplayTiming timing);

}  // namespace lec6::twin
