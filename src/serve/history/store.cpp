#include "store.hpp"

#include <fmt/format.h>
#include <sqlite3.h>

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <limits>
#include <stdexcept>

namespace lec6::serve::history {
namespace {

class SqlError : public std::runtime_error {
 public:
  SqlError(sqlite3* db, const std::string& what)
      : std::runtime_error(fmt::format("{}: {}", what, db ? sqlite3_errmsg(db) : "out of memory")),
        code(db ? sqlite3_errcode(db) : SQLITE_NOMEM) {}
  int code;
};

void exec(sqlite3* db, const char* sql) {
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

constexpr const char* kSchema = R"(
CREATE TABLE IF NOT EXISTS motions (
  id INTEGER PRIMARY KEY, start_ms INTEGER NOT NULL, axis TEXT NOT NULL, source TEXT,
  kind TEXT, step INTEGER, start_mm REAL, target_mm REAL, speed_mm_s REAL, accel_mm_s2 REAL,
  force_pct REAL, pushing_force_pct REAL, outcome TEXT, busy_up_s REAL, busy_down_s REAL,
  inp_s REAL, duration_s REAL, settle_s REAL, peak_thrust_pct REAL, mean_thrust_pct REAL,
  peak_speed_mm_s REAL, overshoot_mm REAL, final_error_mm REAL, distance_mm REAL, alarms TEXT,
  duration_pm_s REAL);
CREATE INDEX IF NOT EXISTS motions_axis_start ON motions (axis, start_ms);
CREATE TABLE IF NOT EXISTS odometer (
  axis TEXT PRIMARY KEY, moves INTEGER, distance_mm REAL, motion_s REAL, pushes INTEGER,
  alarms INTEGER);
CREATE TABLE IF NOT EXISTS services (
  axis TEXT, what TEXT, at_ms INTEGER, moves INTEGER, distance_mm REAL, motion_s REAL,
  pushes INTEGER, alarms INTEGER, PRIMARY KEY (axis, what));
CREATE TABLE IF NOT EXISTS drift_groups (
  axis TEXT, group_id INTEGER, state TEXT, PRIMARY KEY (axis, group_id));
)";

constexpr const char* kColumns =
    "id, start_ms, axis, source, kind, step, start_mm, target_mm, speed_mm_s, accel_mm_s2, "
    "force_pct, pushing_force_pct, outcome, busy_up_s, busy_down_s, inp_s, duration_s, settle_s, "
    "peak_thrust_pct, mean_thrust_pct, peak_speed_mm_s, overshoot_mm, final_error_mm, "
    "distance_mm, alarms, duration_pm_s";

std::string alarms_text(const std::vector<int>& codes) {
  std::string out;
  for (int c : codes) out += fmt::format("{}{}", out.empty() ? "" : " ", c);
  return out;
}

std::vector<int> alarms_of(const std::string& text) {
  std::vector<int> out;
  std::size_t i = 0;
  while (i < text.size()) {
    std::size_t used = 0;
    try {
      out.push_back(std::stoi(text.substr(i), &used));
    } catch (const std::exception&) {
      break;
    }
    i += used + 1;
  }
  return out;
}

MotionRecord record_of(const Stmt& s) {
  MotionRecord r;
  r.id = s.i64(0);
  r.start_ms = s.i64(1);
  r.axis = s.text(2);
  r.source = s.text(3);
  r.kind = s.text(4);
  if (const auto step = s.opt(5)) r.step = static_cast<int>(*step);
  r.start_mm = s.opt(6);
  r.target_mm = s.opt(7);
  r.speed_mm_s = s.opt(8);
  r.accel_mm_s2 = s.opt(9);
  r.force_pct = s.opt(10);
  r.pushing_force_pct = s.opt(11);
  r.outcome = s.text(12);
  r.busy_up_s = s.opt(13);
  r.busy_down_s = s.opt(14);
  r.inp_s = s.opt(15);
  r.duration_s = s.opt(16).value_or(std::numeric_limits<double>::quiet_NaN());
  r.settle_s = s.opt(17);
  r.peak_thrust_pct = s.opt(18);
  r.mean_thrust_pct = s.opt(19);
  r.peak_speed_mm_s = s.opt(20);
  r.overshoot_mm = s.opt(21);
  r.final_error_mm = s.opt(22);
  r.distance_mm = s.f64(23);
  r.alarms = alarms_of(s.text(24));
  r.duration_pm_s = s.opt(25);
  return r;
}

Odometer odometer_of(const Stmt& s, int first) {
  Odometer o;
  o.moves = s.i64(first);
  o.distance_mm = s.f64(first + 1);
  o.motion_s = s.f64(first + 2);
  o.pushes = s.i64(first + 3);
  o.alarms = s.i64(first + 4);
  return o;
}

}  // namespace

Store::Store(StoreConfig config, Log log) : config_(std::move(config)), log_(std::move(log)) {
  if (!config_.now_ms) config_.now_ms = system_ms;
  std::string why;
  if (config_.file.empty()) {
    stats_.disabled_reason =
        "move history off: no state directory (no --state-dir, history.state_dir, "
        "$STATE_DIRECTORY, $XDG_STATE_HOME or $HOME)";
    log_(LogLevel::Warning, stats_.disabled_reason + " (the lines run without it)");
    return;
  }
  bool in_use = false;
  for (int attempt = 0; attempt < 2; ++attempt) {
    bool corrupt = false;
    try {
      if (open(config_.file)) break;
    } catch (const InUse& e) {
      why = e.what();
      in_use = true;
    } catch (const CorruptFile& e) {
      why = e.what();
      corrupt = true;
    } catch (const std::exception& e) {
      why = e.what();
      const int code = writer_ ? sqlite3_errcode(writer_) : SQLITE_OK;
      corrupt = code == SQLITE_NOTADB || code == SQLITE_CORRUPT;
    }
    if (writer_) sqlite3_close_v2(writer_);
    if (reader_) sqlite3_close_v2(reader_);
    writer_ = reader_ = nullptr;
    // Only a broken file is moved aside (never one another process holds).
    if (!corrupt || attempt == 1) break;
    move_aside(why);
  }
  if (!writer_) {
    stats_.disabled_reason =
        fmt::format("move history off: cannot use {}: {}", config_.file.string(), why);
    log_(in_use ? LogLevel::Warning : LogLevel::Error,
         stats_.disabled_reason +
             " (the lines run without it; --state-dir DIR keeps it elsewhere, "
             "--no-history turns it off)");
    return;
  }
  stats_.file_bytes = file_bytes();
  thread_ = std::thread([this] { writer_loop(); });
}

Store::~Store() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
  if (reader_) sqlite3_close_v2(reader_);
  if (writer_) sqlite3_close_v2(writer_);
  if (lock_fd_ >= 0) ::close(lock_fd_);
}

// One daemon per file (issue 32: the history is on by default, and two
// daemons of one user share the default directory): an exclusive lock on
// <file>.lock, held while the store is open. The second gets a clear
// "in use" and runs without history (store_test.cpp
// ASecondStoreOnTheSameFileIsRefusedNotMixedIn).
void Store::lock_file(const std::filesystem::path& file) {
  if (lock_fd_ >= 0) return;
  const std::string lock = file.string() + ".lock";
  const int fd = ::open(lock.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (fd < 0) {
    throw std::runtime_error(fmt::format("cannot make {}: {}", lock, std::strerror(errno)));
  }
  if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
    const int e = errno;
    ::close(fd);
    if (e == EWOULDBLOCK) {
      throw InUse(fmt::format("another lec serve keeps its history there (it holds {})", lock));
    }
    throw std::runtime_error(fmt::format("cannot lock {}: {}", lock, std::strerror(e)));
  }
  lock_fd_ = fd;
}

// Opens (or makes) the file and checks it. Throws saying what is wrong.
bool Store::open(const std::filesystem::path& file) {
  std::error_code ec;
  std::filesystem::create_directories(file.parent_path(), ec);
  lock_file(file);
  const int flags = SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE | SQLITE_OPEN_NOMUTEX;
  if (sqlite3_open_v2(file.c_str(), &writer_, flags, nullptr) != SQLITE_OK) {
    throw SqlError(writer_, "opening");
  }
  sqlite3_busy_timeout(writer_, config_.busy_timeout_ms);
  // auto_vacuum only takes effect before the first table: a new file gets it.
  exec(writer_, "PRAGMA auto_vacuum = INCREMENTAL");
  {
    Stmt check(writer_, "PRAGMA quick_check");
    while (check.step()) {
      if (check.text(0) != "ok") throw CorruptFile("quick_check: " + check.text(0));
    }
  }
  exec(writer_, "PRAGMA journal_mode = WAL");
  // FULL (issue 32, docs/history.md "Storage"): with WAL, NORMAL may lose the
  // last committed records on a power cut; FULL syncs the WAL at each commit,
  // one fsync per batch (a batch is a motion or a few), so a committed record
  // survives a power cut too.
  exec(writer_, "PRAGMA synchronous = FULL");
  // The WAL stays within a tenth of the size limit: checkpoints come that often.
  const uint64_t tenth = std::max<uint64_t>(config_.max_bytes / 10, 64 * 1024);
  exec(writer_, fmt::format("PRAGMA journal_size_limit = {}", tenth).c_str());
  exec(writer_,
       fmt::format("PRAGMA wal_autocheckpoint = {}", std::max<uint64_t>(tenth / 4096, 16)).c_str());
  exec(writer_, kSchema);
  {  // a file of an older version: the column issue 32 added
    bool has_pm = false;
    Stmt cols(writer_, "PRAGMA table_info(motions)");
    while (cols.step()) has_pm = has_pm || cols.text(1) == "duration_pm_s";
    if (!has_pm) exec(writer_, "ALTER TABLE motions ADD COLUMN duration_pm_s REAL");
  }
  if (sqlite3_open_v2(file.c_str(), &reader_, SQLITE_OPEN_READONLY | SQLITE_OPEN_NOMUTEX,
                      nullptr) != SQLITE_OK) {
    throw SqlError(reader_, "opening for queries");
  }
  sqlite3_busy_timeout(reader_, 5000);
  load();
  prune(true);
  return true;
}

void Store::move_aside(const std::string& why) {
  const auto aside = config_.file.string() + fmt::format(".corrupt-{}", config_.now_ms() / 1000);
  std::error_code ec;
  if (!std::filesystem::exists(config_.file, ec)) return;
  std::filesystem::rename(config_.file, aside, ec);
  for (const char* suffix : {"-wal", "-shm"}) {
    std::error_code ignored;
    std::filesystem::rename(config_.file.string() + suffix, aside + suffix, ignored);
  }
  log_(LogLevel::Warning,
       ec ? fmt::format("move history: {} is unusable ({}) and could not be moved aside: {}",
                        config_.file.string(), why, ec.message())
          : fmt::format("move history: {} is unusable ({}): moved aside to {}, starting a new one",
                        config_.file.string(), why, aside));
}

void Store::load() {
  {
    Stmt s(writer_, "SELECT COALESCE(MAX(id), 0) FROM motions");
    if (s.step()) first_free_id_ = s.i64(0) + 1;
  }
  {
    Stmt s(writer_, "SELECT axis, moves, distance_mm, motion_s, pushes, alarms FROM odometer");
    while (s.step()) odometers_[s.text(0)] = odometer_of(s, 1);
  }
  {
    Stmt s(writer_,
           "SELECT axis, what, moves, distance_mm, motion_s, pushes, alarms FROM services");
    while (s.step()) services_[{s.text(0), s.text(1)}] = odometer_of(s, 2);
  }
  Stmt s(writer_, "SELECT axis, state FROM drift_groups ORDER BY axis, group_id");
  while (s.step()) drift_states_[s.text(0)].push_back(s.text(1));
}

bool Store::append(MotionRecord record, Odometer odometer_after, std::vector<DriftRow> drift) {
  std::unique_lock lock(mutex_);
  if (!writer_ || stopping_) return false;
  if (queue_.size() >= config_.queue_capacity) {
    ++stats_.dropped;
    const bool first = !dropping_;
    dropping_ = true;
    lock.unlock();
    if (first) {
      log_(LogLevel::Warning,
           fmt::format("move history: the writer is {} records behind; records are dropped "
                       "until it catches up (the odometer stays exact)",
                       config_.queue_capacity));
    }
    return false;
  }
  const std::string axis = record.axis;
  queue_.push_back({std::move(record), odometer_after, axis, {}, std::move(drift)});
  ++enqueued_;
  lock.unlock();
  wake_.notify_one();
  return true;
}

bool Store::drift(const std::string& axis, std::vector<DriftRow> rows) {
  std::unique_lock lock(mutex_);
  if (!writer_ || stopping_ || rows.empty()) return false;
  queue_.push_back({std::nullopt, Odometer{}, axis, {}, std::move(rows)});
  ++enqueued_;
  lock.unlock();
  wake_.notify_one();
  return true;
}

bool Store::service(const std::string& axis, const std::string& what, const Odometer& at) {
  std::unique_lock lock(mutex_);
  if (!writer_ || stopping_) return false;
  queue_.push_back({std::nullopt, at, axis, what, {}});
  ++enqueued_;
  lock.unlock();
  wake_.notify_one();
  return true;
}

void Store::flush() {
  std::unique_lock lock(mutex_);
  const uint64_t target = enqueued_;
  written_.wait(lock, [&] { return committed_ >= target || !thread_.joinable(); });
}

void Store::writer_loop() {
  std::unique_lock lock(mutex_);
  for (;;) {
    wake_.wait(lock, [this] { return stopping_ || !queue_.empty(); });
    if (queue_.empty() && stopping_) break;
    std::deque<Item> batch;
    batch.swap(queue_);
    dropping_ = false;
    lock.unlock();
    const std::size_t n = batch.size();
    // Issue 32: a lock held past the busy timeout (a sqlite3 shell), a full
    // disk: the same batch again after 0.5, 1 and 2 s before it is given up
    // (and logged as such). Shutdown does not wait for the pauses.
    std::string why;
    for (int attempt = 0; !write_batch(batch, why); ++attempt) {
      if (attempt == 3) {
        log_(LogLevel::Error, fmt::format("move history: {} records not written to {} after 4 "
                                          "attempts: {}",
                                          n, config_.file.string(), why));
        break;
      }
      log_(LogLevel::Warning, fmt::format("move history: writing {} records failed ({}); "
                                          "trying again",
                                          n, why));
      lock.lock();
      ++stats_.retried;
      wake_.wait_for(lock, std::chrono::milliseconds(500 << attempt), [this] { return stopping_; });
      lock.unlock();
    }
    try {  // after COMMIT: a failure here loses nothing written
      const int64_t now = config_.now_ms();
      const bool by_age = now - last_age_prune_ms_ > 3'600'000;
      if (by_age || logical_bytes() > config_.max_bytes * 85 / 100) prune(by_age);
    } catch (const std::exception& e) {
      log_(LogLevel::Warning,
           fmt::format("move history: retention could not delete old records (the new ones are "
                       "written): {}",
                       e.what()));
    }
    lock.lock();
    committed_ += n;
    stats_.file_bytes = file_bytes();
    written_.notify_all();
  }
}

bool Store::write_batch(const std::deque<Item>& batch, std::string& why) {
  try {
    exec(writer_, "BEGIN");
    Stmt insert(writer_, fmt::format("INSERT OR REPLACE INTO motions ({}) VALUES ({})", kColumns,
                                     "?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?"));
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
    Stmt del(writer_,
             "DELETE FROM motions WHERE id IN (SELECT id FROM motions ORDER BY id LIMIT ?)");
    del.bind(1, std::max<int64_t>(rows - keep, 0));
    del.step();
    deleted += static_cast<uint64_t>(sqlite3_changes(writer_));
  }
  if (deleted == 0) return;
  exec(writer_, "PRAGMA incremental_vacuum");
  exec(writer_, "PRAGMA wal_checkpoint(TRUNCATE)");
  std::lock_guard lock(mutex_);
  stats_.pruned += deleted;
}

std::vector<MotionRecord> Store::query(const HistoryQuery& q) const {
  std::vector<MotionRecord> out;
  if (!reader_) return out;
  std::string sql = fmt::format("SELECT {} FROM motions WHERE axis = ?", kColumns);
  if (q.since_ms) sql += " AND start_ms >= ?";
  if (q.until_ms) sql += " AND start_ms < ?";
  if (q.kind) sql += " AND kind = ?";
  if (q.outcome) sql += " AND outcome = ?";
  if (q.source) sql += " AND source LIKE ? ESCAPE '\\'";  // starts with
  if (q.step) sql += " AND step = ?";
  // Newest first by start_ms (issue 32): the (axis, start_ms) index holds the
  // rowid (id) too, so it gives this order without a sort. Paging goes on
  // from the page's last record: older start, or the same start and a lower id.
  std::lock_guard lock(reader_mutex_);
  std::optional<int64_t> before_start;
  if (q.before_id) {
    Stmt b(reader_, "SELECT start_ms FROM motions WHERE id = ?");
    b.bind(1, *q.before_id);
    if (b.step()) before_start = b.i64(0);
  }
  if (before_start) {
    sql += " AND (start_ms < ? OR (start_ms = ? AND id < ?))";
  } else if (q.before_id) {
    sql += " AND id < ?";  // the record is gone (retention): by id
  }
  sql += " ORDER BY start_ms DESC, id DESC LIMIT ?";
  Stmt s(reader_, sql);
  int i = 1;
  s.bind(i++, q.axis);
  if (q.since_ms) s.bind(i++, *q.since_ms);
  if (q.until_ms) s.bind(i++, *q.until_ms);
  if (q.kind) s.bind(i++, *q.kind);
  if (q.outcome) s.bind(i++, *q.outcome);
  if (q.source) {
    std::string pattern;
    for (char ch : *q.source) {
      if (ch == '%' || ch == '_' || ch == '\\') pattern += '\\';
      pattern += ch;
    }
    s.bind(i++, pattern + "%");
  }
  if (q.step) s.bind(i++, int64_t{*q.step});
  if (before_start) {
    s.bind(i++, *before_start);
    s.bind(i++, *before_start);
  }
  if (q.before_id) s.bind(i++, *q.before_id);
  s.bind(i++, static_cast<int64_t>(q.limit));
  while (s.step()) out.push_back(record_of(s));
  return out;
}

StoreStats Store::stats() const {
  std::lock_guard lock(mutex_);
  StoreStats s = stats_;
  s.queued = queue_.size();
  return s;
}

}  // namespace lec6::serve::history
