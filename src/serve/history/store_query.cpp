// The store's queries (store.hpp): on the reader connection, newest first
// along the (axis, start_ms) index.

#include <fmt/format.h>
#include <sqlite3.h>

#include <mutex>

#include "store.hpp"
#include "store_sql.hpp"

namespace lec6::serve::history {

using namespace store_sql;

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
    // `start_ms <= ?` bounds the index range; the OR alone would make SQLite
    // walk the axis from its newest record down to the page's start.
    sql += " AND start_ms <= ? AND (start_ms < ? OR id < ?)";
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

}  // namespace lec6::serve::history
