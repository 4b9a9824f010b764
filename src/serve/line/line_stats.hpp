#pragma once
// What a line did, for `GET /metrics`, the dashboard's bus page and the
// benchmarks: transactions per second, utilisation of the line's limit,
// latency per priority, errors per controller.
//
// Utilisation is Σ (the limit of each transaction: query wire + Ts + 4 ms +
// Td + reply wire, digest §1, plus the Ts of silence a master must leave
// before its next query) / elapsed time, over a sliding window: 1.0 means
// transactions back to back at the fastest the manual's rules allow.
//
// Thread safety: none; the scheduler that owns it is driven by one thread.

#include <array>
#include <cstdint>
#include <deque>
#include <map>
#include <vector>

#include "lec6/clock.hpp"
#include "line/priority.hpp"

namespace lec6::serve {

// Latency histogram bounds (ms), Prometheus-style cumulative buckets.
inline constexpr std::array<double, 13> kLatencyBucketsMs{0.5, 1,   2,   5,    10,   20,  50,
                                                          100, 200, 500, 1000, 2000, 5000};

struct LatencyStats {
  uint64_t count = 0;
  double sum_ms = 0;
  std::array<uint64_t, kLatencyBucketsMs.size()> buckets{};  // cumulative: ≤ bound
  double p50_ms = 0;
  double p99_ms = 0;
  // Submit → the request's frame on the wire (its first attempt), of the
  // requests that reached the line: how long a stop waits behind the queue.
  double wait_p50_ms = 0;
  double wait_p99_ms = 0;
  double wait_max_ms = 0;
  uint64_t wait_count = 0;
  // Emergency only: the last waits, oldest first (each stop's own figure).
  std::vector<double> recent_waits_ms;
};

struct DeviceCounters {
  uint64_t transactions = 0;  // exchanges on the line (answered or not)
  uint64_t answers = 0;       // replies, including exception replies
  uint64_t timeouts = 0;
  uint64_t crc_errors = 0;
  uint64_t framing_errors = 0;
  uint64_t exceptions = 0;
  // Writes to it that would start motion, refused because a stop to it came
  // first (Failure::Superseded): never on the wire, each told to its sender.
  uint64_t superseded = 0;
  TimePoint last_answer{};  // epoch when never
};

enum class ExchangeResult : uint8_t { Answered, Exception, Timeout, Crc, Framing, Other };

struct LineStatsSnapshot {
  double transactions_per_s = 0;
  double utilisation = 0;  // of the line's limit, see above
  double busy = 0;         // fraction of the window the line was in a transaction
  uint64_t transactions = 0;
  uint64_t cache_hits = 0;
  std::array<std::size_t, kPriorities> queue_depth{};
  std::array<LatencyStats, kPriorities> latency{};
  std::map<uint8_t, DeviceCounters> devices;
};

class LineStats {
 public:
  explicit LineStats(TimePoint start, Duration window = std::chrono::seconds(10));

  // One exchange on the wire: [start, end], its limit, and how it ended.
  void exchange(uint8_t id, TimePoint start, TimePoint end, Duration limit, ExchangeResult result);
  // A request answered (from the line or the cache), submit → reply.
  void latency(Priority p, Duration d);
  // A request's first attempt went on the wire `d` after its submit.
  void wait(Priority p, Duration d);
  void cache_hit() { ++cache_hits_; }
  // A start to `id` superseded by a stop (not an exchange: no transaction counted).
  void superseded(uint8_t id) { ++devices_[id].superseded; }

  LineStatsSnapshot snapshot(TimePoint now,
                             const std::array<std::size_t, kPriorities>& queue_depth) const;
  // One controller's counters alone: no percentiles (cheap enough for every sample).
  DeviceCounters device(uint8_t id) const {
    const auto it = devices_.find(id);
    return it == devices_.end() ? DeviceCounters{} : it->second;
  }

 private:
  struct Sample {
    TimePoint end;
    Duration limit;
    Duration busy;
  };
  void trim(TimePoint now) const;

  TimePoint start_;
  Duration window_;
  mutable std::deque<Sample> recent_;
  uint64_t transactions_ = 0;
  uint64_t cache_hits_ = 0;
  std::array<LatencyStats, kPriorities> latency_{};
  std::array<std::vector<double>, kPriorities> recent_latency_ms_;  // ring, for percentiles
  std::array<std::size_t, kPriorities> ring_next_{};
  std::array<std::vector<double>, kPriorities> recent_wait_ms_;  // ring, for percentiles
  std::array<std::size_t, kPriorities> wait_next_{};
  std::array<double, kPriorities> wait_max_ms_{};
  std::array<uint64_t, kPriorities> wait_count_{};
  std::map<uint8_t, DeviceCounters> devices_;
};

}  // namespace lec6::serve
