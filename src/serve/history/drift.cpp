#include "drift.hpp"
#include "drift_group.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include <nlohmann/json.hpp>

namespace lec6::serve::history {
namespace {

double median(std::vector<double> v) {
  std::erase_if(v, [](double x) { return std::isnan(x); });
  if (v.empty()) return kNaN;
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  if (v.size() % 2 == 1) return *mid;
  const double hi = *mid;
  const double lo = *std::max_element(v.begin(), mid);
  return (lo + hi) / 2;
}

bool same(const std::optional<double>& a, const std::optional<double>& b) {
  if (a.has_value() != b.has_value()) return false;
  return !a || std::abs(*a - *b) < 1e-9;
}

bool near(const std::optional<double>& a, const std::optional<double>& b, double tol) {
  if (a.has_value() != b.has_value()) return false;
  return !a || std::abs(*a - *b) <= tol;
}

std::string describe(const MotionRecord& r) {
  std::string out = r.kind;
  if (r.step) out += fmt::format(" step {}", *r.step);
  if (r.target_mm) out += fmt::format(" to {:.2f} mm", *r.target_mm);
  if (r.start_mm) out += fmt::format(" from {:.2f} mm", *r.start_mm);
  if (r.speed_mm_s) out += fmt::format(" at {:g} mm/s", *r.speed_mm_s);
  if (r.accel_mm_s2) out += fmt::format(", accel {:g} mm/s²", *r.accel_mm_s2);
  if (r.force_pct) out += fmt::format(", force {:g} %", *r.force_pct);
  if (r.pushing_force_pct) out += fmt::format(", pushing {:g} %", *r.pushing_force_pct);
  return out;
}

Values values_of(const MotionRecord& r) {
  return {r.duration_s, r.peak_thrust_pct.value_or(kNaN), r.settle_s.value_or(0.0)};
}

}  // namespace

const char* metric_name(Metric m) {
  switch (m) {
    case Metric::Duration:
      return "duration_s";
    case Metric::PeakThrust:
      return "peak_thrust_pct";
    case Metric::Settle:
      return "settle_s";
  }
  return "?";
}

DriftDetector::DriftDetector(DriftConfig config) : config_(config) {}
DriftDetector::~DriftDetector() = default;

DriftDetector::Group* DriftDetector::find_or_make(const MotionRecord& r) {
  auto& groups = axes_[r.axis];
  for (Group& g : groups) {
    const MotionRecord& k = g.key;
    if (k.kind == r.kind && k.step == r.step && same(k.speed_mm_s, r.speed_mm_s) &&
        same(k.accel_mm_s2, r.accel_mm_s2) && same(k.force_pct, r.force_pct) &&
        same(k.pushing_force_pct, r.pushing_force_pct) &&
        near(k.start_mm, r.start_mm, config_.tolerance_mm) &&
        near(k.target_mm, r.target_mm, config_.tolerance_mm)) {
      return &g;
    }
  }
  if (groups.size() >= config_.max_groups_per_axis) {
    const auto lru =
        std::min_element(groups.begin(), groups.end(),
                         [](const Group& a, const Group& b) { return a.last_use < b.last_use; });
    changed_[r.axis][lru->id] = false;
    groups.erase(lru);
  }
  Group g;
  g.id = next_group_id_++;
  g.key = r;
  g.description = describe(r);
  groups.push_back(std::move(g));
  return &groups.back();
}

std::vector<DriftEvent> DriftDetector::add(const MotionRecord& r) {
  if (!r.succeeded() || r.kind == "jog") return {};
  Group& g = *find_or_make(r);
  g.last_use = ++use_counter_;
  changed_[r.axis][g.id] = true;
  ++g.moves;
  Values v = values_of(r);
  // Issue 32: a duration known only to ± more than a quarter of the drift
  // threshold (polls far apart, a busy line) is not judged: the move still
  // counts for thrust and settle time, and the group says how many it skipped.
  if (!std::isnan(v[0]) && r.duration_pm_s &&
      *r.duration_pm_s > config_.max_uncertainty_fraction * config_.threshold * v[0]) {
    v[0] = kNaN;
  }
  if (std::isnan(v[0])) ++g.skipped_duration;
  g.trend.push_back({r.id, r.start_ms, {v[0], v[1], v[2]}});
  while (g.trend.size() > config_.trend_points) g.trend.pop_front();
  return judge(g, r, v);
}

std::vector<DriftEvent> DriftDetector::judge(Group& g, const MotionRecord& r, const Values& v) {
  std::vector<DriftEvent> events;
  if (g.rebase) {
    // The settings changed under this group: what comes now is the new normal.
    g.rebase = false;
    g.ready = false;
    g.baseline.clear();
    g.window.clear();
    for (auto& w : g.warning) {
      if (w) events.push_back({false, *w});
      w.reset();
    }
  }
  if (!g.ready) {
    g.baseline.push_back(v);
    if (g.baseline.size() < config_.baseline_moves) return events;
    for (int m = 0; m < kMetrics; ++m) {
      std::vector<double> xs;
      for (const Values& b : g.baseline) xs.push_back(b[static_cast<std::size_t>(m)]);
      const double med = median(xs);
      std::vector<double> dev;
      for (double x : xs) dev.push_back(std::abs(x - med));
      g.reference[static_cast<std::size_t>(m)] = med;
      g.spread[static_cast<std::size_t>(m)] = 1.4826 * median(dev);
    }
    g.ready = true;
    g.baseline.clear();
    return events;
  }
  g.window.push_back({r.id, r.start_ms, v});
  while (g.window.size() > config_.window) g.window.pop_front();
  if (g.window.size() < config_.window) return events;

  const double floors[kMetrics] = {config_.floor_duration_s, config_.floor_thrust_pct,
                                   config_.floor_settle_s};
  bool quiet = true;
  for (std::size_t m = 0; m < kMetrics; ++m) {
    std::vector<double> xs;
    for (const auto& s : g.window) xs.push_back(s.v[m]);
    const double current = median(xs);
    const double ref = g.reference[m];
    if (std::isnan(current) || std::isnan(ref)) continue;
    const double allowed =
        std::max({config_.threshold * std::abs(ref),
                  config_.spread_factor * 1.2533 * g.spread[m] / std::sqrt(double(config_.window)),
                  floors[m]});
    const double excess = current - ref;
    auto& w = g.warning[m];
    if (!w && excess > allowed) {
      DriftWarning out;
      out.axis = r.axis;
      out.group = g.description;
      out.group_id = g.id;
      out.metric = static_cast<Metric>(m);
      out.reference = ref;
      out.current = current;
      out.drift_pct = ref != 0 ? 100 * excess / std::abs(ref) : 0;
      out.raised_ms = r.start_ms;
      out.since_ms = r.start_ms;
      for (const auto& s : g.window) {
        out.moves.push_back(s.id);
        if (s.v[m] - ref > allowed) out.since_ms = std::min(out.since_ms, s.start_ms);
      }
      w = out;
      events.push_back({true, out});
    } else if (w && excess < config_.clear_fraction * allowed) {
      w->current = current;
      w->drift_pct = ref != 0 ? 100 * excess / std::abs(ref) : 0;
      events.push_back({false, *w});
      w.reset();
    } else if (w) {
      w->current = current;
      w->drift_pct = ref != 0 ? 100 * excess / std::abs(ref) : 0;
    }
    if (w || excess > config_.clear_fraction * allowed) quiet = false;
  }
  if (quiet) {
    // The slow reference: follows a group that stays well inside its band.
    for (std::size_t m = 0; m < kMetrics; ++m) {
      if (std::isnan(v[m]) || std::isnan(g.reference[m])) continue;
      g.reference[m] += config_.reference_rate * (v[m] - g.reference[m]);
    }
  }
  return events;
}

void DriftDetector::settings_changed(const std::string& axis, std::optional<int> step) {
  const auto it = axes_.find(axis);
  if (it == axes_.end()) return;
  for (Group& g : it->second) {
    if (!g.key.step) continue;  // direct moves carry their own settings
    if (!step || g.key.step == step) g.rebase = true, changed_[axis][g.id] = true;
  }
}

std::vector<DriftWarning> DriftDetector::warnings(const std::string& axis) const {
  std::vector<DriftWarning> out;
  const auto it = axes_.find(axis);
  if (it == axes_.end()) return out;
  for (const Group& g : it->second) {
    for (const auto& w : g.warning) {
      if (w) out.push_back(*w);
    }
  }
  return out;
}

std::vector<GroupView> DriftDetector::groups(const std::string& axis) const {
  std::vector<GroupView> out;
  const auto it = axes_.find(axis);
  if (it == axes_.end()) return out;
  for (const Group& g : it->second) {
    GroupView v;
    v.group_id = g.id;
    v.axis = axis;
    v.description = g.description;
    v.moves = g.moves;
    v.skipped_duration = g.skipped_duration;
    v.baseline_ready = g.ready;
    for (std::size_t m = 0; m < kMetrics; ++m) {
      v.reference[m] = g.reference[m];
      v.spread[m] = g.spread[m];
    }
    v.trend = g.trend;
    out.push_back(std::move(v));
  }
  return out;
}

nlohmann::json to_json(const DriftWarning& w) {
  return {{"axis", w.axis},
          {"group", w.group},
          {"group_id", w.group_id},
          {"metric", metric_name(w.metric)},
          {"reference", w.reference},
          {"current", w.current},
          {"drift_pct", std::round(w.drift_pct * 10) / 10},
          {"since", iso_time(w.since_ms)},
          {"raised", iso_time(w.raised_ms)},
          {"moves", w.moves},
          {"message", fmt::format("{} of {} rose {:.1f} % (from {:.3g} to {:.3g}) since {}",
                                  metric_name(w.metric), w.group, w.drift_pct, w.reference,
                                  w.current, iso_time(w.since_ms))}};
}

}  // namespace lec6::serve::history
