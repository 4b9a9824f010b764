#include "fit_offsets.hpp"

#include <algorithm>

namespace lec6::serve::history {
namespace {

FitOffsets::Range common(const std::deque<FitOffsets::Range>& moves) {
  FitOffsets::Range r = moves.front();
  for (const auto& m : moves) r = {std::max(r.lo, m.lo), std::min(r.hi, m.hi)};
  return r;
}

}  // namespace

FitOffsets::Range FitOffsets::add(const std::string& key, Range move) {
  if (!keys_.contains(key) && keys_.size() >= kOffsetKeys) {
    keys_.erase(std::min_element(keys_.begin(), keys_.end(), [](const auto& a, const auto& b) {
      return a.second.last_use < b.second.last_use;
    }));
  }
  Seen& s = keys_[key];
  s.last_use = ++uses_;
  s.moves.push_back(move);
  while (s.moves.size() > kOffsetMoves) s.moves.pop_front();
  Range r = common(s.moves);
  if (r.hi < r.lo) {
    // The moves disagree: c is not what it was. Start again from this one.
    s.moves = {move};
    r = move;
  }
  return r;
}

}  // namespace lec6::serve::history
