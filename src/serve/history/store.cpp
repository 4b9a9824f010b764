// The store's life: opening (or moving aside) the file, the lock, loading
// the odometers and drift state, and the writer thread's queue (store.hpp).
// Writing a batch and retention: store_write.cpp; queries: store_query.cpp.

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
#include "store_sql.hpp"

namespace lec6::serve::history {

using namespace store_sql;

namespace {
constexpr std::size_t kMaxBatch = 256;  // records in one transaction
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
  // The WAL stays within a tenth of the size limit: checkpoints come when it
  // passes a twentieth, so the transaction that passes it (kMaxBatch records
  // at most) still ends within the tenth.
  const uint64_t tenth = std::max<uint64_t>(config_.max_bytes / 10, 64 * 1024);
  exec(writer_, fmt::format("PRAGMA journal_size_limit = {}", tenth).c_str());
  exec(writer_,
       fmt::format("PRAGMA wal_autocheckpoint = {}", std::max<uint64_t>(tenth / 2 / 4096, 16))
           .c_str());
  exec(writer_, kSchema);
  {  // a file of an older version: the columns issue 32 added
    bool has_pm = false, has_timed_by = false;
    Stmt cols(writer_, "PRAGMA table_info(motions)");
    while (cols.step()) {
      has_pm = has_pm || cols.text(1) == "duration_pm_s";
      has_timed_by = has_timed_by || cols.text(1) == "timed_by";
    }
    if (!has_pm) exec(writer_, "ALTER TABLE motions ADD COLUMN duration_pm_s REAL");
    if (!has_timed_by) exec(writer_, "ALTER TABLE motions ADD COLUMN timed_by TEXT");
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
    // A transaction's pages go to the WAL before a checkpoint can take them:
    // at most kMaxBatch records in one, so the WAL stays near its tenth of
    // the size limit however much was queued.
    std::deque<Item> batch;
    if (queue_.size() <= kMaxBatch) {
      batch.swap(queue_);
    } else {
      const auto end = queue_.begin() + static_cast<std::ptrdiff_t>(kMaxBatch);
      batch.assign(std::make_move_iterator(queue_.begin()), std::make_move_iterator(end));
      queue_.erase(queue_.begin(), end);
    }
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

StoreStats Store::stats() const {
  std::lock_guard lock(mutex_);
  StoreStats s = stats_;
  s.queued = queue_.size();
  return s;
}

}  // namespace lec6::serve::history
