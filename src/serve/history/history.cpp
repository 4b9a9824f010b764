#include "history.hpp"

#include <fmt/format.h>

#include <chrono>
#include <cmath>

#include "state_dir.hpp"

namespace lec6::serve::history {
namespace {

DriftConfig drift_config(const HistoryConfig& c) {
  DriftConfig d;
  d.threshold = c.drift_threshold_pct / 100;
  d.baseline_moves = c.drift_baseline_moves;
  d.tolerance_mm = c.drift_tolerance_mm;
  return d;
}

std::vector<ServiceThreshold> thresholds(const HistoryConfig& c) {
  std::vector<ServiceThreshold> out;
  for (const auto& s : c.services)
    out.push_back({s.what, s.every_km, s.every_moves, s.every_hours});
  return out;
}

}  // namespace

History::History(const HistoryConfig& config, std::vector<std::string> axes, Log log,
                 std::function<int64_t()> wall_ms)
    : config_(config),
      log_(std::move(log)),
      wall_ms_(wall_ms ? std::move(wall_ms) : std::function<int64_t()>(system_ms)),
      drift_(drift_config(config)) {
  StoreConfig sc;
  std::string where_from;
  if (config_.state_dir.empty()) {  // on by default (issue 32): state_dir.hpp
    if (const auto d = default_state_dir()) {
      config_.state_dir = d->dir;
      where_from = fmt::format(
          " (the default, from {}; --state-dir DIR keeps it elsewhere, "
          "--no-history keeps none)",
          d->from);
    }
  }
  if (!config_.state_dir.empty()) sc.file = config_.state_dir / "history.db";
  sc.max_age_days = config_.max_age_days;
  sc.max_bytes = static_cast<uint64_t>(config_.max_size_mb * 1024 * 1024);
  sc.queue_capacity = config_.queue;
  sc.now_ms = wall_ms_;
  store_ = std::make_unique<Store>(sc, log_);
  next_id_ = store_->first_free_id();
  odometers_ = store_->odometers();
  services_ = store_->services();
  // Drift baselines, references and active warnings carry on (issue 32).
  for (const auto& [axis, rows] : store_->drift_states()) {
    std::vector<nlohmann::json> groups;
    for (const auto& text : rows) {
      auto j = nlohmann::json::parse(text, nullptr, false);
      if (!j.is_discarded()) groups.push_back(std::move(j));
    }
    drift_.restore(axis, groups);
  }
  for (const auto& a : axes) trackers_.emplace(a, MotionTracker(a));
  if (store_->ok()) {
    log_(LogLevel::Info, fmt::format("move history in {} ({} records so far){}", sc.file.string(),
                                     next_id_ - 1, where_from));
  }
}

History::~History() = default;

std::filesystem::path History::state_dir() const {
  return store_->ok() ? config_.state_dir : std::filesystem::path();
}

void History::add_listener(Listener l) {
  std::lock_guard lock(mutex_);
  listeners_.push_back(std::move(l));
}

void History::on_op_event(const std::string& axis, const nlohmann::json& event, TimePoint at) {
  std::optional<MotionRecord> done;
  {
    std::lock_guard lock(mutex_);
    const auto it = trackers_.find(axis);
    if (it == trackers_.end()) return;
    done = it->second.op_event(event, at, wall_ms_());
  }
  // A step written through lec serve: the steps' moves start new baselines.
  if (event.value("event", "") == "finished" && event.value("op", "") == "step-write" &&
      event.value("ok", false)) {
    on_step_table_edit(axis, event.contains("step") && event["step"].is_number_integer()
                                 ? std::optional<int>(event["step"].get<int>())
                                 : std::nullopt);
  }
  if (done) record(std::move(*done));
}

void History::on_telemetry(const std::string& axis, const AxisSnapshot& s, TimePoint at,
                           TimePoint started) {
  std::optional<MotionRecord> done;
  {
    std::lock_guard lock(mutex_);
    const auto it = trackers_.find(axis);
    if (it == trackers_.end()) return;
    done = it->second.telemetry(s.state, s.flags, at, wall_ms_(),
                                started == TimePoint{} ? std::nullopt : std::optional(started));
  }
  if (done) record(std::move(*done));
}

void History::on_step_table_edit(const std::string& axis, std::optional<int> step) {
  std::lock_guard lock(mutex_);
  drift_.settings_changed(axis, step);
  store_->drift(axis, drift_rows(axis));
}

// The drift groups changed since the last call, for the store (locked).
std::vector<DriftRow> History::drift_rows(const std::string& axis) {
  std::vector<DriftRow> rows;
  for (auto& [id, state] : drift_.take_changed(axis))
    rows.push_back({id, state.is_null() ? std::string() : state.dump()});
  return rows;
}

bool History::serviced(const std::string& axis, const std::string& what) {
  Odometer at;
  {
    std::lock_guard lock(mutex_);
    const bool known = std::any_of(config_.services.begin(), config_.services.end(),
                                   [&](const auto& s) { return s.what == what; });
    if (!known) return false;
    at = odometers_[axis];
    services_[{axis, what}] = at;
  }
  store_->service(axis, what, at);
  return true;
}

void History::record(MotionRecord r) {
  std::vector<DriftEvent> events;
  nlohmann::json health;
  std::vector<Listener> listeners;
  {
    std::lock_guard lock(mutex_);
    r.id = next_id_++;
    Odometer& odo = odometers_[r.axis];
    odo.add(r);
    events = drift_.add(r);
    store_->append(r, odo, drift_rows(r.axis));
    health = health_locked(r.axis);
    listeners = listeners_;
  }
  for (const auto& e : events) {
    log_(LogLevel::Warning,
         e.raised
             ? fmt::format("drift on {}: {}", r.axis,
                           to_json(e.warning)["message"].get<std::string>())
             : fmt::format("drift on {} cleared: {} of {} is back within {:.1f} %", r.axis,
                           metric_name(e.warning.metric), e.warning.group, e.warning.drift_pct));
  }
  if (listeners.empty()) return;
  const nlohmann::json record = to_json(r);
  for (const auto& l : listeners) {
    l(r.axis, "history", record);
    for (const auto& e : events) {
      nlohmann::json j = to_json(e.warning);
      j["raised"] = e.raised;
      l(r.axis, "drift", j);
    }
    l(r.axis, "health", health);
  }
}

std::vector<ServiceNotice> History::notices_of(const std::string& axis) const {
  std::vector<ServiceNotice> out;
  const auto odo = odometers_.find(axis);
  if (odo == odometers_.end()) return out;
  for (const auto& t : thresholds(config_)) {
    const auto done = services_.find({axis, t.what});
    for (auto& n : notices(odo->second, done == services_.end() ? Odometer{} : done->second, {t})) {
      out.push_back(std::move(n));
    }
  }
  return out;
}

nlohmann::json History::health_locked(const std::string& axis, bool trend) const {
  using nlohmann::json;
  const auto odo = odometers_.find(axis);
  json warnings = json::array();
  for (const auto& w : drift_.warnings(axis)) warnings.push_back(to_json(w));
  json notes = json::array();
  for (const auto& n : notices_of(axis))
    notes.push_back({{"what", n.what}, {"message", n.message}});
  json groups = json::array();
  for (const auto& g : drift_.groups(axis)) {
    json baseline = nullptr;
    if (g.baseline_ready) {
      baseline = json::object();
      for (int m = 0; m < kMetrics; ++m) {
        baseline[metric_name(static_cast<Metric>(m))] = {{"reference", g.reference[m]},
                                                         {"spread", g.spread[m]}};
      }
    }
    groups.push_back({{"group_id", g.group_id},
                      {"group", g.description},
                      {"moves", g.moves},
                      {"durations_skipped", g.skipped_duration},
                      {"baseline", baseline}});
    if (trend) {
      json points = json::array();
      for (const auto& p : g.trend) {
        points.push_back(
            {{"id", p.id},
             {"start_ms", p.start_ms},
             {"duration_s", p.values[0]},
             {"peak_thrust_pct", std::isnan(p.values[1]) ? json(nullptr) : json(p.values[1])},
             {"settle_s", p.values[2]}});
      }
      groups.back()["trend"] = points;
    }
  }
  const StoreStats st = store_->stats();
  json storage = {{"written", st.written}, {"dropped", st.dropped}, {"pruned", st.pruned},
                  {"retried", st.retried}, {"queued", st.queued},   {"file_bytes", st.file_bytes}};
  if (!st.disabled_reason.empty()) storage["disabled"] = st.disabled_reason;
  return {{"axis", axis},
          {"ok", warnings.empty() && notes.empty()},
          {"odometer", to_json(odo == odometers_.end() ? Odometer{} : odo->second)},
          {"service", notes},
          {"warnings", warnings},
          {"groups", groups},
          {"storage", storage}};
}

nlohmann::json History::health(const std::string& axis, bool trend) const {
  std::lock_guard lock(mutex_);
  return health_locked(axis, trend);
}

std::vector<MotionRecord> History::query(const HistoryQuery& q) const {
  store_->flush();
  return store_->query(q);
}

bool History::query_async(HistoryQuery q, std::function<void(std::vector<MotionRecord>)> done) {
  return queries_.post([this, q = std::move(q), done = std::move(done)] { done(query(q)); });
}

}  // namespace lec6::serve::history
