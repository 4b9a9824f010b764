#pragma once
// Dating a move by the wire (issue 32): a start or a poll is timed by when
// its exchange was on the wire (Master::last_wire_times), not by when its
// reply reached the thread that asked, so queueing and thread wake-up on a
// busy line (lec serve) do not shift a motion's timeline. Where the master
// does not know its wire times, the reply's arrival is used, as before.
// Private to the client library.

#include "lec6/client/client.hpp"
#include "lec6/client/completion.hpp"

namespace lec6::client::detail {

// The MoveStart of the start request just sent on `c`.
inline MoveStart wire_dated(MoveStart s, const Client& c) {
  if (const auto w = c.last_wire_times(); w && w->replied <= s.at) {
    s.at = w->replied;
    s.sent_at = w->sent;
  }
  return s;
}

// A poll whose flags were the last exchange on `c`, `at` their arrival.
inline Poll wire_dated(Poll p, const std::optional<WireTimes>& w) {
  if (w && w->replied <= p.at) {
    p.at = w->replied;
    p.sent_at = w->sent;
  }
  return p;
}

}  // namespace lec6::client::detail
