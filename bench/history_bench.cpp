// The move history's costs (docs/history.md, BENCHMARKS.md "Move history"):
//   - a query for one axis and one day over 10^5 records (goal: < 50 ms);
//   - what recording one motion costs the process (the caller's part: the
//     tracker's bookkeeping, the drift detector, the queue; plus the writer
//     thread's SQLite transaction), in CPU per motion: at a motion a second
//     per axis, CPU share = this × motions per second.

#include <benchmark/benchmark.h>
#include <unistd.h>

#include <filesystem>
#include <memory>
#include <random>

#include "serve/history/history.hpp"

namespace {

using namespace lec6::serve;
using namespace lec6::serve::history;

constexpr int64_t kDay = 86'400'000;
constexpr int64_t kT0 = 1'790'000'000'000;

std::filesystem::path temp_dir() {
  char tmpl[] = "/tmp/lec6-history-bench-XXXXXX";
  return mkdtemp(tmpl);
}

MotionRecord motion(int64_t i, std::mt19937& rng) {
  std::normal_distribution<double> n(0, 0.02);
  MotionRecord r;
  r.start_ms = kT0 + i * 8640;  // 10^5 records over 10 days: 10^4 a day
  r.axis = i % 2 ? "x" : "y";
  r.source = "http 127.0.0.1";
  r.kind = "move";
  r.start_mm = i % 4 < 2 ? 10 : 150;
  r.target_mm = i % 4 < 2 ? 150 : 10;
  r.speed_mm_s = 100;
  r.outcome = "reached";
  r.busy_up_s = 0.01;
  r.busy_down_s = 1.5 * (1 + n(rng));
  r.inp_s = *r.busy_down_s + 0.02;
  r.duration_s = *r.busy_down_s;
  r.settle_s = 0.02;
  r.peak_thrust_pct = 40 * (1 + n(rng));
  r.mean_thrust_pct = 20;
  r.peak_speed_mm_s = 100;
  r.overshoot_mm = 0.01;
  r.final_error_mm = 0;
  r.distance_mm = 140;
  return r;
}

void quiet(LogLevel, std::string_view) {}

void BM_HistoryQuery_OneAxisOneDay(benchmark::State& state) {
  const auto dir = temp_dir();
  HistoryConfig c;
  c.state_dir = dir;
  c.queue = 200'000;
  {
    History h(c, {"x", "y"}, quiet, [] { return kT0 + 10 * kDay; });
    std::mt19937 rng(1);
    for (int64_t i = 0; i < 100'000; ++i) h.record(motion(i, rng));
    h.flush();
  }
  StoreConfig sc;
  sc.file = dir / "history.db";
  sc.now_ms = [] { return kT0 + 10 * kDay; };
  Store store(sc, quiet);
  HistoryQuery q;
  q.axis = "x";
  q.since_ms = kT0 + 5 * kDay;
  q.until_ms = kT0 + 6 * kDay;
  q.limit = 10000;
  std::size_t n = 0;
  for (auto _ : state) {
    n = store.query(q).size();
    benchmark::DoNotOptimize(n);
  }
  state.counters["records_in_file"] = 100'000;
  state.counters["records_returned"] = static_cast<double>(n);
  std::filesystem::remove_all(dir);
}
BENCHMARK(BM_HistoryQuery_OneAxisOneDay)->Unit(benchmark::kMillisecond);

// Process CPU (every thread: the caller and the writer) per motion recorded.
void BM_HistoryRecord_ProcessCpuPerMotion(benchmark::State& state) {
  const auto dir = temp_dir();
  HistoryConfig c;
  c.state_dir = dir;
  auto h = std::make_unique<History>(c, std::vector<std::string>{"x", "y"}, quiet);
  std::mt19937 rng(2);
  int64_t i = 0;
  for (auto _ : state) {
    h->record(motion(i++, rng));
    if (i % 64 == 0) h->flush();  // keep the writer's work inside the timing
  }
  h->flush();
  h.reset();
  std::filesystem::remove_all(dir);
}
BENCHMARK(BM_HistoryRecord_ProcessCpuPerMotion)
    ->MeasureProcessCPUTime()
    ->UseRealTime()
    ->Unit(benchmark::kMicrosecond);

}  // namespace
