#pragma once
// The emergency lane of a line's scheduler (sans-I/O): the stops, holds and
// resets (client::stops_or_releases, the one rule) waiting for the wire, kept
// per controller so that one controller's stops cannot delay another's
// (issue 31 rule 2):
//
//   - controllers take turns: one exchange each, round robin;
//   - a controller that answers goes before one that does not (its last
//     exchange failed), except that non-answering ones get one exchange
//     where the answering ones' round begins again, once they have waited
//     `backoff`: so a stop to an answering controller waits for at most the
//     transaction on the wire, one exchange for a non-answering controller,
//     and one exchange for each other controller with a stop queued that
//     counts as answering (one whose reply is lost then costs a lost
//     exchange: nobody can know before) — per stop to the same controller
//     queued ahead of it;
//   - a non-answering controller's stop keeps its attempts, but after a
//     failed attempt it waits `backoff` before the next (other traffic, not
//     only other stops, goes meanwhile);
//   - a stop identical to the last one queued for the same controller (same
//     request, not yet on the wire) joins it: one exchange, both submitters
//     answered (only the last: joining an earlier one would reorder writes).
//     A PLC rewriting its output image every scan then holds one entry, not
//     hundreds.
//
// Attacked by tests/serve/line/emergency_lane_test.cpp and the deterministic
// line simulation (tests/serve/sim/).
//
// Thread safety: none; the scheduler's driver serialises every call.

#include <deque>
#include <functional>
#include <map>
#include <optional>
#include <vector>

#include "lec6/clock.hpp"
#include "line/job.hpp"

namespace lec6::serve {

class EmergencyLane {
 public:
  explicit EmergencyLane(Duration backoff) : backoff_(backoff) {}

  // A new stop: joins an identical one queued for its controller, or queues.
  // Returns true when it joined. `under`: the controller whose turn it takes
  // (its own unless given).
  bool push(Queued q, std::optional<uint8_t> under = std::nullopt);
  // A write queued before a stop, moved here so that the wire sees it before
  // the stop: queued under the stop's controller `under` (a broadcast write
  // before a stop to ID 1, or any ID's write before a broadcast stop, would
  // otherwise take another controller's turn, after the stop's). Joined only
  // as a write of levels identical to the last one queued there.
  void push_in_order(Queued q, uint8_t under);
  // A stop whose exchange failed and has attempts left: first in its
  // controller's queue again. `answering`: whether the controller still
  // counts as answering (only its replies may be lost); if not, it waits
  // `backoff` first.
  void retry(Queued q, bool answering, TimePoint now);
  // The stop to put on the wire now, if any. `answering(id)`: whether the
  // controller answered its last exchange.
  std::optional<Queued> pop(TimePoint now, const std::function<bool(uint8_t)>& answering);

  // When a stop that waits for its backoff may go.
  std::optional<TimePoint> wake_at() const;
  bool ready(TimePoint now) const;
  bool empty() const noexcept { return size_ == 0; }
  std::size_t size() const noexcept { return size_; }
  // Every queued stop, in no particular order (the line went down).
  std::vector<Queued> take_all();
  // The entries `pred` picks, taken out in queue order (a start that a
  // release moved here, superseded by a later hard stop: scheduler.cpp).
  std::vector<Queued> take_if(const std::function<bool(const Queued&)>& pred);

 private:
  struct Controller {
    std::deque<Queued> jobs;
    TimePoint not_before{};     // backoff after a failed attempt
    TimePoint waiting_since{};  // when its front became ready
  };
  std::optional<Queued> take(std::map<uint8_t, Controller>::iterator it, bool answering);
  std::optional<std::map<uint8_t, Controller>::iterator> next_after(
      uint8_t last, bool want_answering, TimePoint now,
      const std::function<bool(uint8_t)>& answering);

  Duration backoff_;
  std::map<uint8_t, Controller> controllers_;
  std::map<uint8_t, TimePoint> backoff_until_;  // per controller, beyond its queued stops
  std::size_t size_ = 0;
  uint8_t last_answering_ = 0;       // round robin of the answering controllers
  uint8_t last_silent_ = 0;          // and of the non-answering ones
  bool last_was_answering_ = false;  // the last stop served went to an answering one
};

}  // namespace lec6::serve
