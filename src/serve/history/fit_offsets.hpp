#pragma once
// What the position fit (profile_fit.hpp) cannot see, learned from the polls
// (issue 32; a reviewer's cases): ramps that are not the trapezoid written
// (an S-curve, an acceleration the actuator clamps), a servo's following
// error, BUSY held after the motion ends. Each makes a move's true duration
// longer (or shorter) than its fitted one by an offset c that is the same for
// every move of the same settings. A move's BUSY brackets are hard bounds of
// its true duration, and its fit is the model's duration to within its ±, so
// each move says c lies in [lo, hi]; the recent moves of one setting together
// pin c down to the intersection, which narrows as the polls' phases vary,
// at any line load. An empty intersection (c changed: the axis or its
// controller behave otherwise now) starts again from the latest move.
// Sans-I/O; not persisted (after a restart c is learned again within a few
// moves; until then those durations are the brackets').
//
// Thread safety: none (the tracker's owner locks).

#include <cstdint>
#include <deque>
#include <map>
#include <string>

namespace lec6::serve::history {

inline constexpr std::size_t kOffsetMoves = 200;  // recent moves per setting
inline constexpr std::size_t kOffsetKeys = 64;    // settings kept per axis (least recent go)

class FitOffsets {
 public:
  struct Range {
    double lo = 0, hi = 0;
  };
  // `key`: the move's settings; `move`: what this move allows of c. Returns
  // what the recent moves of the key allow together (never empty).
  Range add(const std::string& key, Range move);

 private:
  struct Seen {
    std::deque<Range> moves;
    uint64_t last_use = 0;
  };
  std::map<std::string, Seen> keys_;
  uint64_t uses_ = 0;
};

}  // namespace lec6::serve::history
