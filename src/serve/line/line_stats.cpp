#include "line/line_stats.hpp"

#include <algorithm>

namespace lec6::serve {
namespace {

constexpr std::size_t kRing = 2048;  // latency samples kept per priority for percentiles

void keep(std::vector<double>& ring, std::size_t& next, double v) {
  if (ring.size() < kRing) {
    ring.push_back(v);
  } else {
    ring[next] = v;
    next = (next + 1) % kRing;
  }
}

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0;
  const auto k = static_cast<std::size_t>(p * static_cast<double>(v.size() - 1) + 0.5);
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

}  // namespace

LineStats::LineStats(TimePoint start, Duration window) : start_(start), window_(window) {}

void LineStats::exchange(uint8_t id, TimePoint start, TimePoint end, Duration limit,
                         ExchangeResult result) {
  recent_.push_back({end, limit, end - start});
  ++transactions_;
  auto& d = devices_[id];
  ++d.transactions;
  switch (result) {
    case ExchangeResult::Answered:
      ++d.answers;
      d.last_answer = end;
      break;
    case ExchangeResult::Exception:
      ++d.answers;
      ++d.exceptions;
      d.last_answer = end;
      break;
    case ExchangeResult::Timeout:
      ++d.timeouts;
      break;
    case ExchangeResult::Crc:
      ++d.crc_errors;
      break;
    case ExchangeResult::Framing:
      ++d.framing_errors;
      break;
    case ExchangeResult::Other:
      break;
  }
}

void LineStats::latency(Priority p, Duration d) {
  const double ms = to_ms(d);
  auto& l = latency_[index(p)];
  ++l.count;
  l.sum_ms += ms;
  for (std::size_t i = 0; i < kLatencyBucketsMs.size(); ++i) {
    if (ms <= kLatencyBucketsMs[i]) ++l.buckets[i];
  }
  keep(recent_latency_ms_[index(p)], ring_next_[index(p)], ms);
}

void LineStats::wait(Priority p, Duration d) {
  const double ms = to_ms(d);
  keep(recent_wait_ms_[index(p)], wait_next_[index(p)], ms);
  wait_max_ms_[index(p)] = std::max(wait_max_ms_[index(p)], ms);
  ++wait_count_[index(p)];
}

void LineStats::trim(TimePoint now) const {
  while (!recent_.empty() && recent_.front().end < now - window_) recent_.pop_front();
}

LineStatsSnapshot LineStats::snapshot(
    TimePoint now, const std::array<std::size_t, kPriorities>& queue_depth) const {
  trim(now);
  LineStatsSnapshot s;
  const Duration span = std::min(window_, now - start_);
  if (span > Duration{}) {
    Duration limit{}, busy{};
    for (const Sample& x : recent_) limit += x.limit, busy += x.busy;
    const double seconds = to_seconds(span);
    s.transactions_per_s = static_cast<double>(recent_.size()) / seconds;
    s.utilisation = to_seconds(limit) / seconds;
    s.busy = to_seconds(busy) / seconds;
  }
  s.transactions = transactions_;
  s.cache_hits = cache_hits_;
  s.queue_depth = queue_depth;
  s.latency = latency_;
  for (std::size_t p = 0; p < kPriorities; ++p) {
    s.latency[p].p50_ms = percentile(recent_latency_ms_[p], 0.50);
    s.latency[p].p99_ms = percentile(recent_latency_ms_[p], 0.99);
    s.latency[p].wait_p50_ms = percentile(recent_wait_ms_[p], 0.50);
    s.latency[p].wait_p99_ms = percentile(recent_wait_ms_[p], 0.99);
    s.latency[p].wait_max_ms = wait_max_ms_[p];
    s.latency[p].wait_count = wait_count_[p];
  }
  // The last emergency waits, oldest first: the ring starts at its next slot once full.
  constexpr std::size_t kRecent = 16;
  const auto& ring = recent_wait_ms_[index(Priority::Emergency)];
  const std::size_t n = std::min(kRecent, ring.size());
  const std::size_t newest =
      ring.size() < kRing ? ring.size() : wait_next_[index(Priority::Emergency)];
  auto& recent = s.latency[index(Priority::Emergency)].recent_waits_ms;
  for (std::size_t i = n; i > 0; --i) recent.push_back(ring[(newest + kRing - i) % kRing]);
  s.devices = devices_;
  return s;
}

}  // namespace lec6::serve
