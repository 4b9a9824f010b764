// The drift detector's state in and out of the store (issue 32): each group's
// key, baseline (or the moves it is still learning from), reference, spread,
// window and active warnings, as JSON. NaN (no thrust sampled) is null.

#include <algorithm>
#include <cmath>

#include <nlohmann/json.hpp>

#include "drift.hpp"
#include "drift_group.hpp"

namespace lec6::serve::history {
namespace {

using nlohmann::json;

json num(double v) {
  return std::isnan(v) ? json(nullptr) : json(v);
}
double num_of(const json& j) {
  return j.is_number() ? j.get<double>() : kNaN;
}
json values(const Values& v) {
  return json::array({num(v[0]), num(v[1]), num(v[2])});
}
Values values_of(const json& j) {
  Values v{kNaN, kNaN, kNaN};
  for (std::size_t m = 0; m < kMetrics && j.is_array() && m < j.size(); ++m) v[m] = num_of(j[m]);
  return v;
}
json opt(const std::optional<double>& v) {
  return v ? json(*v) : json(nullptr);
}
std::optional<double> opt_of(const json& j, const char* key) {
  const auto it = j.find(key);
  if (it == j.end() || !it->is_number()) return std::nullopt;
  return it->get<double>();
}

json warning(const DriftWarning& w) {
  return {{"group", w.group},         {"metric", static_cast<int>(w.metric)},
          {"reference", w.reference}, {"current", w.current},
          {"drift_pct", w.drift_pct}, {"since_ms", w.since_ms},
          {"raised_ms", w.raised_ms}, {"moves", w.moves}};
}
DriftWarning warning_of(const json& j, const std::string& axis, int group_id) {
  DriftWarning w;
  w.axis = axis;
  w.group_id = group_id;
  w.group = j.value("group", "");
  w.metric = static_cast<Metric>(std::clamp(j.value("metric", 0), 0, kMetrics - 1));
  w.reference = j.value("reference", 0.0);
  w.current = j.value("current", 0.0);
  w.drift_pct = j.value("drift_pct", 0.0);
  w.since_ms = j.value("since_ms", int64_t{0});
  w.raised_ms = j.value("raised_ms", int64_t{0});
  w.moves = j.value("moves", std::vector<int64_t>{});
  return w;
}

}  // namespace

json DriftDetector::save(const Group& g) {
  const MotionRecord& k = g.key;
  json window = json::array();
  for (const auto& s : g.window) window.push_back({s.id, s.start_ms, values(s.v)});
  json baseline = json::array();
  for (const auto& b : g.baseline) baseline.push_back(values(b));
  json warnings = json::array();
  for (const auto& w : g.warning) warnings.push_back(w ? warning(*w) : json(nullptr));
  return {{"v", 1},
          {"id", g.id},
          {"key",
           {{"kind", k.kind},
            {"step", k.step ? json(*k.step) : json(nullptr)},
            {"speed_mm_s", opt(k.speed_mm_s)},
            {"accel_mm_s2", opt(k.accel_mm_s2)},
            {"force_pct", opt(k.force_pct)},
            {"pushing_force_pct", opt(k.pushing_force_pct)},
            {"start_mm", opt(k.start_mm)},
            {"target_mm", opt(k.target_mm)}}},
          {"description", g.description},
          {"last_use", g.last_use},
          {"moves", g.moves},
          {"skipped_duration", g.skipped_duration},
          {"ready", g.ready},
          {"rebase", g.rebase},
          {"reference", values(g.reference)},
          {"spread", values(g.spread)},
          {"baseline", baseline},
          {"window", window},
          {"warnings", warnings}};
}

DriftDetector::Group DriftDetector::load(const json& j) {
  Group g;
  g.id = j.at("id").get<int>();
  const json& k = j.at("key");
  g.key.kind = k.value("kind", "");
  if (const auto s = opt_of(k, "step")) g.key.step = static_cast<int>(*s);
  g.key.speed_mm_s = opt_of(k, "speed_mm_s");
  g.key.accel_mm_s2 = opt_of(k, "accel_mm_s2");
  g.key.force_pct = opt_of(k, "force_pct");
  g.key.pushing_force_pct = opt_of(k, "pushing_force_pct");
  g.key.start_mm = opt_of(k, "start_mm");
  g.key.target_mm = opt_of(k, "target_mm");
  g.description = j.value("description", "");
  g.last_use = j.value("last_use", uint64_t{0});
  g.moves = j.value("moves", std::size_t{0});
  g.skipped_duration = j.value("skipped_duration", std::size_t{0});
  g.ready = j.value("ready", false);
  g.rebase = j.value("rebase", false);
  g.reference = values_of(j.value("reference", json::array()));
  g.spread = values_of(j.value("spread", json::array()));
  for (const auto& b : j.value("baseline", json::array())) g.baseline.push_back(values_of(b));
  for (const auto& s : j.value("window", json::array())) {
    g.window.push_back({s.at(0).get<int64_t>(), s.at(1).get<int64_t>(), values_of(s.at(2))});
  }
  return g;
}

std::vector<std::pair<int, json>> DriftDetector::take_changed(const std::string& axis) {
  std::vector<std::pair<int, json>> out;
  const auto it = changed_.find(axis);
  if (it == changed_.end()) return out;
  for (const auto& [id, there] : it->second) {
    json state = nullptr;
    if (there) {
      for (const Group& g : axes_[axis]) {
        if (g.id == id) state = save(g);
      }
    }
    out.emplace_back(id, std::move(state));
  }
  changed_.erase(it);
  return out;
}

void DriftDetector::restore(const std::string& axis, const std::vector<json>& groups) {
  auto& mine = axes_[axis];
  for (const json& j : groups) {
    try {
      Group g = load(j);
      const json& ws = j.value("warnings", json::array());
      for (std::size_t m = 0; m < kMetrics && m < ws.size(); ++m) {
        if (ws[m].is_object()) g.warning[m] = warning_of(ws[m], axis, g.id);
      }
      next_group_id_ = std::max(next_group_id_, g.id + 1);
      use_counter_ = std::max(use_counter_, g.last_use);
      mine.push_back(std::move(g));
    } catch (const std::exception&) {
      // A row this version cannot read: that group learns its baseline again.
    }
  }
  // The most recently used first, at most max_groups_per_axis (a row of an
  // evicted group whose deletion did not reach the disk is dropped here).
  std::sort(mine.begin(), mine.end(),
            [](const Group& a, const Group& b) { return a.last_use > b.last_use; });
  if (mine.size() > config_.max_groups_per_axis) mine.resize(config_.max_groups_per_axis);
}

}  // namespace lec6::serve::history
