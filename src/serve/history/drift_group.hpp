#pragma once
// A drift group's state (drift.hpp): private to drift.cpp and
// drift_state.cpp (its persistence).

#include <array>
#include <deque>
#include <limits>
#include <optional>
#include <vector>

#include "drift.hpp"

namespace lec6::serve::history {

inline constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
using Values = std::array<double, kMetrics>;

struct DriftDetector::Group {
  int id = 0;
  MotionRecord key;  // the first move's settings
  std::string description;
  uint64_t last_use = 0;
  std::size_t moves = 0;
  std::size_t skipped_duration = 0;  // moves whose duration was too uncertain, or unknown
  std::vector<Values> baseline;
  bool ready = false;
  bool rebase = false;
  Values reference{}, spread{};
  struct Seen {
    int64_t id, start_ms;
    Values v;
  };
  std::deque<Seen> window;
  std::array<std::optional<DriftWarning>, kMetrics> warning;
  std::deque<GroupView::Point> trend;
};

}  // namespace lec6::serve::history
