// The store's writer: one transaction per batch, retried by the caller, and
// retention by age and size after its COMMIT (store.hpp).

#include <fmt/format.h>
#include <sqlite3.h>

#include <algorithm>
#include <cstdint>
#include <filesystem>

#include "store.hpp"
#include "store_sql.hpp"

namespace lec6::serve::history {

using namespace store_sql;

bool Store::write_batch(const std::deque<Item>& batch, std::string& why) {
  try {
    exec(writer_, "BEGIN");
    Stmt insert(writer_, fmt::format("INSERT OR REPLACE INTO motions ({}) VALUES ({})", kColumns,
                                     "?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?"));
    Stmt odo(writer_,
             "INSERT OR REPLACE INTO odometer (axis, moves, distance_mm, motion_s, pushes, alarms) "
             "VALUES (?,?,?,?,?,?)");
    Stmt svc(writer_,
             "INSERT OR REPLACE INTO services (axis, what, at_ms, moves, distance_mm, motion_s, "
             "pushes, alarms) VALUES (?,?,?,?,?,?,?,?)");
    Stmt drift_put(writer_,
                   "INSERT OR REPLACE INTO drift_groups (axis, group_id, state) VALUES (?,?,?)");
    Stmt drift_gone(writer_, "DELETE FROM drift_groups WHERE axis = ? AND group_id = ?");
    std::map<std::string, Odometer> last;
    uint64_t records = 0;
    for (const Item& item : batch) {
      for (const DriftRow& d : item.drift) {
        Stmt& st = d.state.empty() ? drift_gone : drift_put;
        st.bind(1, item.axis);
        st.bind(2, int64_t{d.group_id});
        if (!d.state.empty()) st.bind(3, d.state);
        st.step();
        st.reset();
      }
      if (!item.record && item.service_what.empty()) continue;  // drift rows alone
      if (!item.record) {
        svc.bind(1, item.axis);
        svc.bind(2, item.service_what);
        svc.bind(3, config_.now_ms());
        svc.bind(4, item.odometer.moves);
        svc.bind(5, item.odometer.distance_mm);
        svc.bind(6, item.odometer.motion_s);
        svc.bind(7, item.odometer.pushes);
        svc.bind(8, item.odometer.alarms);
        svc.step();
        svc.reset();
        continue;
      }
      const MotionRecord& r = *item.record;
      int i = 1;
      insert.bind(i++, r.id);
      insert.bind(i++, r.start_ms);
      insert.bind(i++, r.axis);
      insert.bind(i++, r.source);
      insert.bind(i++, r.kind);
      insert.bind(i++, r.step);
      insert.bind(i++, r.start_mm);
      insert.bind(i++, r.target_mm);
      insert.bind(i++, r.speed_mm_s);
      insert.bind(i++, r.accel_mm_s2);
      insert.bind(i++, r.force_pct);
      insert.bind(i++, r.pushing_force_pct);
      insert.bind(i++, r.outcome);
      insert.bind(i++, r.busy_up_s);
      insert.bind(i++, r.busy_down_s);
      insert.bind(i++, r.inp_s);
      insert.bind(i++, r.duration_s);
      insert.bind(i++, r.settle_s);
      insert.bind(i++, r.peak_thrust_pct);
      insert.bind(i++, r.mean_thrust_pct);
      insert.bind(i++, r.peak_speed_mm_s);
      insert.bind(i++, r.overshoot_mm);
      insert.bind(i++, r.final_error_mm);
      insert.bind(i++, r.distance_mm);
      insert.bind(i++, alarms_text(r.alarms));
      insert.bind(i++, r.duration_pm_s);
      insert.bind(i++, r.timed_by);
      insert.step();
      insert.reset();
      last[item.axis] = item.odometer;
      ++records;
    }
    for (const auto& [axis, o] : last) {
      odo.bind(1, axis);
      odo.bind(2, o.moves);
      odo.bind(3, o.distance_mm);
      odo.bind(4, o.motion_s);
      odo.bind(5, o.pushes);
      odo.bind(6, o.alarms);
      odo.step();
      odo.reset();
    }
    exec(writer_, "COMMIT");
    std::lock_guard lock(mutex_);
    stats_.written += records;
    return true;
  } catch (const std::exception& e) {
    sqlite3_exec(writer_, "ROLLBACK", nullptr, nullptr, nullptr);
    why = e.what();
    return false;
  }
}

// The database's size as SQLite sees it (pages in the WAL included).
uint64_t Store::logical_bytes() const {
  Stmt count(writer_, "PRAGMA page_count");
  Stmt size(writer_, "PRAGMA page_size");
  if (!count.step() || !size.step()) return 0;
  return static_cast<uint64_t>(count.i64(0) * size.i64(0));
}

// The file and its WAL on disk.
uint64_t Store::file_bytes() const {
  std::error_code ec2;
  const auto wal = std::filesystem::file_size(config_.file.string() + "-wal", ec2);
  std::error_code ec;
  const auto main = std::filesystem::file_size(config_.file, ec);
  return (ec ? 0 : main) + (ec2 ? 0 : wal);
}

// Deletes what is too old, then the oldest records until the file is at 70 %
// of max_bytes, and gives the pages back.
void Store::prune(bool by_age) {
  const int64_t now = config_.now_ms();
  uint64_t deleted = 0;
  if (by_age) {
    last_age_prune_ms_ = now;
    Stmt del(writer_, "DELETE FROM motions WHERE start_ms < ?");
    del.bind(1, now - static_cast<int64_t>(config_.max_age_days * 86'400'000.0));
    del.step();
    deleted += static_cast<uint64_t>(sqlite3_changes(writer_));
  }
  auto pragma = [this](const char* sql) {
    Stmt s(writer_, sql);
    return s.step() ? s.i64(0) : int64_t{0};
  };
  const int64_t page = pragma("PRAGMA page_size");
  const int64_t used = (pragma("PRAGMA page_count") - pragma("PRAGMA freelist_count")) * page;
  if (static_cast<uint64_t>(used) > config_.max_bytes * 85 / 100) {
    const int64_t rows = pragma("SELECT COUNT(*) FROM motions");
    const auto keep =
        static_cast<int64_t>(double(rows) * 0.65 * double(config_.max_bytes) / double(used));
    // In four steps, the WAL emptied after each: one DELETE of a fifth of
    // the file writes every page it touches (the table's and its four
    // indexes') to the WAL, which would take the file past its limit.
    const int64_t excess = std::max<int64_t>(rows - keep, 0);
    Stmt del(writer_,
             "DELETE FROM motions WHERE id IN (SELECT id FROM motions ORDER BY id LIMIT ?)");
    for (int part = 0; part < 4; ++part) {
      del.reset();
      del.bind(1, excess / 4 + (part < excess % 4 ? 1 : 0));
      del.step();
      deleted += static_cast<uint64_t>(sqlite3_changes(writer_));
      exec(writer_, "PRAGMA wal_checkpoint(TRUNCATE)");
    }
  }
  if (deleted == 0) return;
  // The pages given back a twentieth of the limit at a time, the WAL emptied
  // after each: the vacuum moves pages, and every page moved is written to
  // the WAL first.
  const int64_t step_pages = std::max<int64_t>(16, int64_t(config_.max_bytes / 20) / page);
  for (int i = 0; i < 100 && pragma("PRAGMA freelist_count") > 0; ++i) {
    exec(writer_, fmt::format("PRAGMA incremental_vacuum({})", step_pages).c_str());
    exec(writer_, "PRAGMA wal_checkpoint(TRUNCATE)");
  }
  std::lock_guard lock(mutex_);
  stats_.pruned += deleted;
}

}  // namespace lec6::serve::history
