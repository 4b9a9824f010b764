#pragma once
// The SQL of the move history's store (store.hpp): the schema, a prepared
// statement, the errors, and a record or an odometer row to and from SQLite.
// Private to serve/history/store*.cpp.
//
// Thread safety: a Stmt is its connection's; the functions are pure.

#include <fmt/format.h>
#include <sqlite3.h>

#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "motion_record.hpp"
#include "odometer.hpp"

namespace lec6::serve::history::store_sql {

class SqlError : public std::runtime_error {
 public:
  SqlError(sqlite3* db, const std::string& what)
      : std::runtime_error(fmt::format("{}: {}", what, db ? sqlite3_errmsg(db) : "out of memory")),
        code(db ? sqlite3_errcode(db) : SQLITE_NOMEM) {}
  int code;
};

inline void exec(sqlite3* db, const char* sql) {
  char* err = nullptr;
  if (sqlite3_exec(db, sql, nullptr, nullptr, &err) != SQLITE_OK) {
    const std::string msg = err ? err : "?";
    sqlite3_free(err);
    throw std::runtime_error(fmt::format("{} ({})", msg, sql));
  }
}

// A prepared statement, finalised when it goes.
class Stmt {
 public:
  Stmt(sqlite3* db, const std::string& sql) : db_(db) {
    if (sqlite3_prepare_v2(db, sql.c_str(), -1, &s_, nullptr) != SQLITE_OK) {
      throw SqlError(db, "preparing " + sql);
    }
  }
  ~Stmt() { sqlite3_finalize(s_); }
  Stmt(const Stmt&) = delete;
  Stmt& operator=(const Stmt&) = delete;

  void bind(int i, int64_t v) { sqlite3_bind_int64(s_, i, v); }
  void bind(int i, double v) { sqlite3_bind_double(s_, i, v); }
  void bind(int i, const std::string& v) {
    sqlite3_bind_text(s_, i, v.data(), static_cast<int>(v.size()), SQLITE_TRANSIENT);
  }
  void bind(int i, const std::optional<double>& v) {
    v ? bind(i, *v) : void(sqlite3_bind_null(s_, i));
  }
  void bind(int i, const std::optional<int>& v) {
    v ? bind(i, int64_t{*v}) : void(sqlite3_bind_null(s_, i));
  }
  bool step() {
    const int rc = sqlite3_step(s_);
    if (rc == SQLITE_ROW) return true;
    if (rc == SQLITE_DONE) return false;
    throw SqlError(db_, "step");
  }
  void reset() {
    sqlite3_reset(s_);
    sqlite3_clear_bindings(s_);
  }
  int64_t i64(int c) const { return sqlite3_column_int64(s_, c); }
  double f64(int c) const { return sqlite3_column_double(s_, c); }
  std::optional<double> opt(int c) const {
    return sqlite3_column_type(s_, c) == SQLITE_NULL ? std::nullopt : std::optional<double>(f64(c));
  }
  std::string text(int c) const {
    const auto* p = sqlite3_column_text(s_, c);
    return p ? reinterpret_cast<const char*>(p) : "";
  }

 private:
  sqlite3* db_;
  sqlite3_stmt* s_ = nullptr;
};

class InUse : public std::runtime_error {  // another daemon holds the file's lock
 public:
  using std::runtime_error::runtime_error;
};

class CorruptFile : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

inline constexpr const char* kSchema = R"(
CREATE TABLE IF NOT EXISTS motions (
  id INTEGER PRIMARY KEY, start_ms INTEGER NOT NULL, axis TEXT NOT NULL, source TEXT,
  kind TEXT, step INTEGER, start_mm REAL, target_mm REAL, speed_mm_s REAL, accel_mm_s2 REAL,
  force_pct REAL, pushing_force_pct REAL, outcome TEXT, busy_up_s REAL, busy_down_s REAL,
  inp_s REAL, duration_s REAL, settle_s REAL, peak_thrust_pct REAL, mean_thrust_pct REAL,
  peak_speed_mm_s REAL, overshoot_mm REAL, final_error_mm REAL, distance_mm REAL, alarms TEXT,
  duration_pm_s REAL, timed_by TEXT);
CREATE INDEX IF NOT EXISTS motions_axis_start ON motions (axis, start_ms);
CREATE INDEX IF NOT EXISTS motions_axis_outcome_start ON motions (axis, outcome, start_ms);
CREATE INDEX IF NOT EXISTS motions_axis_kind_start ON motions (axis, kind, start_ms);
CREATE INDEX IF NOT EXISTS motions_axis_step_start ON motions (axis, step, start_ms);
CREATE TABLE IF NOT EXISTS odometer (
  axis TEXT PRIMARY KEY, moves INTEGER, distance_mm REAL, motion_s REAL, pushes INTEGER,
  alarms INTEGER);
CREATE TABLE IF NOT EXISTS services (
  axis TEXT, what TEXT, at_ms INTEGER, moves INTEGER, distance_mm REAL, motion_s REAL,
  pushes INTEGER, alarms INTEGER, PRIMARY KEY (axis, what));
CREATE TABLE IF NOT EXISTS drift_groups (
  axis TEXT, group_id INTEGER, state TEXT, PRIMARY KEY (axis, group_id));
)";

inline constexpr const char* kColumns =
    "id, start_ms, axis, source, kind, step, start_mm, target_mm, speed_mm_s, accel_mm_s2, "
    "force_pct, pushing_force_pct, outcome, busy_up_s, busy_down_s, inp_s, duration_s, settle_s, "
    "peak_thrust_pct, mean_thrust_pct, peak_speed_mm_s, overshoot_mm, final_error_mm, "
    "distance_mm, alarms, duration_pm_s, timed_by";

std::string alarms_text(const std::vector<int>& codes);  // "52 98"
std::vector<int> alarms_of(const std::string& text);
// A row of `SELECT kColumns FROM motions`.
MotionRecord record_of(const Stmt& s);
// The odometer's five columns from `first` on.
Odometer odometer_of(const Stmt& s, int first);

}  // namespace lec6::serve::history::store_sql
