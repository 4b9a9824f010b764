#pragma once
// lec serve's move history (docs/history.md, issue 26): one record per
// motion, the odometer of each axis, service notices and drift warnings.
//
// Fed by the daemon: Operations' observer (operations.hpp: started /
// finished) and each line's telemetry observer (line.hpp). Both run on other
// threads (operation threads, the line's thread): what they do here is a
// short critical section in memory; the disk is the store's writer thread
// (store.hpp), so the line never waits for the history.
//
// Listeners (SSE, MQTT) get, outside the lock:
//   "history" a record as JSON (motion_record.hpp),
//   "health"  an axis' health (odometer, notices, warnings) after each record,
//   "drift"   a warning raised or cleared ({"raised": bool, ...to_json(warning)}).
//
// Thread safety: every public member may be called from any thread.

#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "drift.hpp"
#include "lec6/serve/config.hpp"
#include "lec6/serve/log.hpp"
#include "line/telemetry_cache.hpp"
#include "odometer.hpp"
#include "query_worker.hpp"
#include "store.hpp"
#include "tracker.hpp"

namespace lec6::serve::history {

using Listener =
    std::function<void(const std::string& axis, std::string_view kind, const nlohmann::json&)>;

class History {
 public:
  // `axes`: the daemon's axis names. The store opens (or is moved aside and
  // made anew) here; a store that cannot work leaves the history in memory.
  History(const HistoryConfig& config, std::vector<std::string> axes, Log log,
          std::function<int64_t()> wall_ms = {});
  ~History();

  void add_listener(Listener l);
  // The observers (any thread). `at`: the line's clock.
  void on_op_event(const std::string& axis, const nlohmann::json& event, TimePoint at);
  // `at`: the read's reply ended; `started`: the read began ({}: at).
  void on_telemetry(const std::string& axis, const AxisSnapshot& snapshot, TimePoint at,
                    TimePoint started = {});
  // A step of the axis' table was written (nullopt: the whole table).
  void on_step_table_edit(const std::string& axis, std::optional<int> step);
  // Marks `what` (a configured service) as done now on `axis`. false: no such service.
  bool serviced(const std::string& axis, const std::string& what);

  // A finished motion, however it was observed (tests feed records here).
  void record(MotionRecord r);

  // `trend`: each group's recent moves too ({"id", "start_ms", duration_s,
  // peak_thrust_pct, settle_s}, up to 300 per group), for the dashboard's plot.
  nlohmann::json health(const std::string& axis, bool trend = false) const;
  // Where the history is kept (the default one resolved), empty when it keeps nothing.
  std::filesystem::path state_dir() const;
  // Sees every record finished before it (waits for the store to commit
  // what is queued): call it off the I/O thread, e.g. through query_async.
  std::vector<MotionRecord> query(const HistoryQuery& q) const;
  // The same on the history's query thread (query_worker.hpp); `done` runs
  // there. false: too many queries waiting (answer 503).
  bool query_async(HistoryQuery q, std::function<void(std::vector<MotionRecord>)> done);
  Store& store() noexcept { return *store_; }
  void flush() { store_->flush(); }

 private:
  std::vector<ServiceNotice> notices_of(const std::string& axis) const;  // locked
  std::vector<DriftRow> drift_rows(const std::string& axis);             // locked
  nlohmann::json health_locked(const std::string& axis, bool trend = false) const;

  HistoryConfig config_;
  Log log_;
  std::function<int64_t()> wall_ms_;
  std::unique_ptr<Store> store_;
  mutable std::mutex mutex_;
  std::map<std::string, MotionTracker> trackers_;
  std::map<std::string, Odometer> odometers_;
  std::map<std::pair<std::string, std::string>, Odometer> services_;
  DriftDetector drift_;
  int64_t next_id_ = 1;
  std::vector<Listener> listeners_;
  QueryWorker queries_;  // last: joined first, while the store is still open
};

}  // namespace lec6::serve::history
