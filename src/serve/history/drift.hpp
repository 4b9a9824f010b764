#pragma once
// Drift detection (sans-I/O): the moves of an axis fall into groups of
// comparable moves (same kind, step, speed, acceleration and force settings;
// start and target within a tolerance). Each group learns a baseline from
// its first `baseline_moves` successful moves: the median and the spread
// (1.4826 × median absolute deviation) of its duration, peak thrust and
// settle time. After that the reference follows the moves very slowly
// (`reference_rate` per move, and only while the group is well inside its
// band), so seasons and run-in are absorbed but wear is not.
//
// A warning is raised for a metric when the median of the group's last
// `window` moves exceeds the reference by more than the largest of
// threshold × reference, `spread_factor` × spread and the metric's absolute
// floor (a settle time of 20 ms that becomes 30 ms is a poll's jitter, not
// +50 %). It clears (hysteresis) when that median falls back below
// reference × (1 + clear_fraction × threshold). A warning names the group,
// the metric, by how much, since when (the start of the first move of the
// window that crossed) and the moves that caused it.
//
// A step-table edit (settings_changed) makes the next move of the affected
// groups start a new baseline: the step change it brings never warns.
//
// Time is what the caller gives (the record's start, Unix ms): no clock here.
// Thread safety: none (the history owns one and locks around it).

#include <array>
#include <cstdint>
#include <deque>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "motion_record.hpp"

namespace lec6::serve::history {

struct DriftConfig {
  double threshold = 0.10;      // +10 %
  double clear_fraction = 0.5;  // clears below +5 %
  std::size_t baseline_moves = 20;
  std::size_t window = 9;
  double spread_factor = 4;
  double reference_rate = 0.0005;  // per move, while within clear_fraction × threshold
  double tolerance_mm = 0.5;       // start and target of comparable moves
  double floor_duration_s = 0.05;
  double floor_thrust_pct = 3;
  double floor_settle_s = 0.05;
  std::size_t max_groups_per_axis = 256;  // the least recently used goes
  std::size_t trend_points = 300;         // kept per group for the dashboard
  // A duration whose ± is above this × threshold × the duration is not judged.
  double max_uncertainty_fraction = 0.25;
};

enum class Metric { Duration, PeakThrust, Settle };
inline constexpr int kMetrics = 3;
const char* metric_name(Metric m);  // "duration_s", "peak_thrust_pct", "settle_s"

struct DriftWarning {
  std::string axis;
  std::string group;  // "move to 150.00 mm from 10.00 mm at 100 mm/s, accel 1000, force 100 %"
  int group_id = 0;
  Metric metric = Metric::Duration;
  double reference = 0;  // the baseline's value
  double current = 0;    // the median of the last window
  double drift_pct = 0;  // (current / reference − 1) × 100
  int64_t since_ms = 0;  // the first move of the window that crossed
  int64_t raised_ms = 0;
  std::vector<int64_t> moves;  // record ids of the window
};

struct DriftEvent {
  bool raised = true;  // false: cleared
  DriftWarning warning;
};

// What a group looks like now (for /health and the dashboard).
struct GroupView {
  int group_id = 0;
  std::string axis, description;
  std::size_t moves = 0;
  std::size_t skipped_duration = 0;  // durations not judged: unknown or too uncertain
  bool baseline_ready = false;
  double reference[kMetrics] = {0, 0, 0};
  double spread[kMetrics] = {0, 0, 0};
  struct Point {
    int64_t id, start_ms;
    double values[kMetrics];
  };
  std::deque<Point> trend;
};

class DriftDetector {
 public:
  explicit DriftDetector(DriftConfig config = {});
  ~DriftDetector();
  DriftDetector(const DriftDetector&) = delete;
  DriftDetector& operator=(const DriftDetector&) = delete;

  // One finished motion; only successful positioning, pushing and homing
  // moves count. Returns the warnings raised or cleared by it.
  std::vector<DriftEvent> add(const MotionRecord& r);
  // The step table of `axis` changed (`step`: one step; nullopt: any).
  void settings_changed(const std::string& axis, std::optional<int> step);

  // Persistence (issue 32: baselines and warnings survive a restart). The
  // groups changed since the last call, as JSON (null: the group is gone),
  // for the store to write with the record that changed them; and the
  // groups read back from it at start (drift_state.cpp). A group's trend
  // (the dashboard's plot) is not kept: it starts again after a restart.
  std::vector<std::pair<int, nlohmann::json>> take_changed(const std::string& axis);
  void restore(const std::string& axis, const std::vector<nlohmann::json>& groups);

  std::vector<DriftWarning> warnings(const std::string& axis) const;
  std::vector<GroupView> groups(const std::string& axis) const;
  const DriftConfig& config() const noexcept { return config_; }

 private:
  struct Group;
  Group* find_or_make(const MotionRecord& r);
  std::vector<DriftEvent> judge(Group& g, const MotionRecord& r,
                                const std::array<double, kMetrics>& v);

  static nlohmann::json save(const Group& g);
  static Group load(const nlohmann::json& j);

  DriftConfig config_;
  std::map<std::string, std::vector<Group>> axes_;
  std::map<std::string, std::map<int, bool>> changed_;  // axis → group id → still there
  int next_group_id_ = 1;
  uint64_t use_counter_ = 0;
};

nlohmann::json to_json(const DriftWarning& w);

}  // namespace lec6::serve::history
