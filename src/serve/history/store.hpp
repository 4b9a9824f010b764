#pragma once
// The history's SQLite database (docs/history.md): motion records, the
// odometer of each axis and the services done, in one file in the daemon's
// state directory.
//
//   - WAL journal: a crash or kill -9 loses at most what was still queued
//     (normally the record in flight), never the file or a committed record;
//     the odometer row is written in the same transaction as its record.
//   - Writes go through a bounded queue to a writer thread of the store's
//     own: callers (operation threads, the line's telemetry observer) never
//     wait for the disk. A full queue drops the record (counted in
//     stats().dropped and logged once per burst); the odometer in memory
//     stays exact and goes out with the next record written.
//   - Retention by age and by size: after each batch, when the file passes
//     85 % of max_bytes, the oldest records are deleted down to 65 % and the
//     pages given back (auto_vacuum = INCREMENTAL, WAL checkpoint TRUNCATE
//     between steps); records older than max_age go once an hour. A
//     transaction holds 256 records at most, so the WAL stays within a
//     tenth of max_bytes (store_test.cpp RetentionBySize...UnderTheLimit).
//   - A file SQLite cannot use (not a database, quick_check fails) is moved
//     aside to <file>.corrupt-<unix time> with a log line, and a new one
//     started. When even that fails the store is disabled (ok() false) and
//     says why: the daemon runs its lines without history.
//
// Queries use a second connection (WAL: readers never wait for the writer).
//
// Thread safety: every public member may be called from any thread.

#include <condition_variable>
#include <cstdint>
#include <deque>
#include <filesystem>
#include <functional>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "lec6/serve/log.hpp"
#include "motion_record.hpp"
#include "odometer.hpp"

struct sqlite3;

namespace lec6::serve::history {

struct StoreConfig {
  std::filesystem::path file;  // <state dir>/history.db
  double max_age_days = 365;
  uint64_t max_bytes = 100ull << 20;
  std::size_t queue_capacity = 4096;
  int busy_timeout_ms = 5000;  // another connection's lock: SQLite waits this long, then a retry
  std::function<int64_t()> now_ms;  // wall clock, Unix ms (tests set it)
};

struct HistoryQuery {
  std::string axis;
  std::optional<int64_t> since_ms, until_ms;  // start_ms in [since, until)
  std::optional<std::string> kind, outcome;
  std::optional<std::string> source;  // starts with: "mqtt" matches "mqtt id 42"
  std::optional<int> step;
  std::optional<int64_t>
      before_id;            // paging: records after this one (older start, or same and lower id)
  std::size_t limit = 100;  // newest first (start_ms, then id)
};

// A drift group's state (drift.hpp take_changed); an empty state: the group is gone.
struct DriftRow {
  int group_id = 0;
  std::string state;  // JSON
};

struct StoreStats {
  uint64_t written = 0, dropped = 0, pruned = 0;
  uint64_t retried = 0;  // batches written again after a failure (a lock, a full disk)
  std::size_t queued = 0;
  uint64_t file_bytes = 0;      // the file and its WAL
  std::string disabled_reason;  // non-empty: the store is off
};

class Store {
 public:
  Store(StoreConfig config, Log log);
  ~Store();  // writes what is queued, then closes
  Store(const Store&) = delete;
  Store& operator=(const Store&) = delete;

  bool ok() const noexcept { return writer_ != nullptr; }
  // The ids the next records take (one more than the largest in the file).
  int64_t first_free_id() const noexcept { return first_free_id_; }
  // The odometers and last services as the file had them when opened.
  const std::map<std::string, Odometer>& odometers() const noexcept { return odometers_; }
  const std::map<std::pair<std::string, std::string>, Odometer>& services() const noexcept {
    return services_;
  }

  // Queues the record with its axis' odometer after it. false: dropped (the
  // queue is full, or the store is off).
  // `drift`: the drift groups this record changed, written in its transaction.
  bool append(MotionRecord record, Odometer odometer_after, std::vector<DriftRow> drift = {});
  // Queues drift group states alone (a step-table edit rebases groups).
  bool drift(const std::string& axis, std::vector<DriftRow> rows);
  // The drift groups' states as the file had them when opened, per axis.
  const std::map<std::string, std::vector<std::string>>& drift_states() const noexcept {
    return drift_states_;
  }
  // Queues "`what` was serviced on `axis` at this odometer".
  bool service(const std::string& axis, const std::string& what, const Odometer& at);
  // Waits until everything queued before it is committed (tests, shutdown).
  void flush();

  std::vector<MotionRecord> query(const HistoryQuery& q) const;
  StoreStats stats() const;

 private:
  struct Item {
    std::optional<MotionRecord> record;
    Odometer odometer;
    std::string axis, service_what;
    std::vector<DriftRow> drift;
  };
  bool open(const std::filesystem::path& file);
  void lock_file(const std::filesystem::path& file);
  void move_aside(const std::string& why);
  void load();
  void writer_loop();
  bool write_batch(const std::deque<Item>& batch, std::string& why);  // false: rolled back
  void prune(bool by_age);
  uint64_t file_bytes() const;
  uint64_t logical_bytes() const;

  StoreConfig config_;
  Log log_;
  int lock_fd_ = -1;  // <file>.lock, held exclusively while open
  sqlite3* writer_ = nullptr;
  sqlite3* reader_ = nullptr;
  mutable std::mutex reader_mutex_;
  int64_t first_free_id_ = 1;
  std::map<std::string, Odometer> odometers_;
  std::map<std::pair<std::string, std::string>, Odometer> services_;
  std::map<std::string, std::vector<std::string>> drift_states_;

  mutable std::mutex mutex_;
  std::condition_variable wake_, written_;
  std::deque<Item> queue_;
  uint64_t enqueued_ = 0, committed_ = 0;
  bool stopping_ = false;
  bool dropping_ = false;  // logged the current burst of drops
  StoreStats stats_;
  int64_t last_age_prune_ms_ = 0;
  std::thread thread_;
};

}  // namespace lec6::serve::history
