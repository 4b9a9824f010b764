// The move history's API queries over a large history.db (issue 32, rule 3;
// BENCHMARKS.md "Move history"): fills a file with N records (4 axes, a mix
// of kinds, steps, sources and outcomes), then times each query
// GET /api/axes/{name}/history offers, as the API runs it (History::
// query_async: on the history's query thread), p50 and p99 over many runs;
// and a stop handler posted to an I/O thread (the daemon's asio io_context,
// which carries HTTP with its stops) while a heavy query runs, against the
// same post on an idle process.
//
//   lec6_history_queries --records 1000000 [--runs 200] [--dir DIR] [--keep]

#include <fmt/format.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <asio.hpp>
#include <chrono>
#include <ctime>
#include <filesystem>
#include <future>
#include <random>
#include <thread>

#include "serve/history/history.hpp"

namespace {

using namespace lec6::serve;
using namespace lec6::serve::history;
using Clock = std::chrono::steady_clock;

constexpr int64_t kT0 = 1'790'000'000'000;
constexpr int64_t kDay = 86'400'000;
const char* const kAxes[] = {"x", "y", "z", "w"};

void quiet(LogLevel, std::string_view) {}

double ms_since(Clock::time_point t) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t).count();
}

// The process' CPU time, ms (every thread: while a query runs, only the query
// thread works; the caller waits).
double cpu_ms() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return double(ts.tv_sec) * 1e3 + double(ts.tv_nsec) / 1e6;
}

MotionRecord motion(int64_t i, int64_t n, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(0, 1);
  MotionRecord r;
  r.id = i + 1;
  r.start_ms = kT0 + i * (100 * kDay / n);  // n records over 100 days
  r.axis = kAxes[i % 4];
  const double k = u(rng);
  r.kind = k < 0.6 ? "move" : k < 0.95 ? "run-step" : k < 0.99 ? "jog" : "home";
  if (r.kind == "run-step") r.step = static_cast<int>(u(rng) * 16);
  r.source = u(rng) < 0.7 ? "http 127.0.0.1" : u(rng) < 0.5 ? "mqtt" : "telemetry";
  const double o = u(rng);
  r.outcome = o < 0.995 ? "reached" : o < 0.998 ? "stopped" : o < 0.999 ? "alarm" : "refused";
  if (r.outcome == "alarm") r.alarms = {149};
  r.start_mm = 10;
  r.target_mm = 150;
  r.busy_up_s = 0.02;
  r.busy_down_s = 1.5;
  r.inp_s = 1.5;
  r.duration_s = 1.48;
  r.duration_pm_s = 0.01;
  r.settle_s = 0;
  r.peak_thrust_pct = 40;
  r.mean_thrust_pct = 20;
  r.peak_speed_mm_s = 100;
  r.distance_mm = 140;
  return r;
}

struct Named {
  std::string name;
  HistoryQuery q;
};

std::vector<Named> api_queries(int64_t n) {
  std::vector<Named> out;
  auto q = [](auto f) {
    HistoryQuery h;
    h.axis = "x";
    f(h);
    return h;
  };
  out.push_back({"default (limit=100)", q([](auto&) {})});
  out.push_back({"limit=10000", q([](auto& h) { h.limit = 10000; })});
  out.push_back({"since+until one day, limit=10000", q([](auto& h) {
                   h.since_ms = kT0 + 50 * kDay;
                   h.until_ms = kT0 + 51 * kDay;
                   h.limit = 10000;
                 })});
  out.push_back({"kind=jog", q([](auto& h) { h.kind = "jog"; })});
  out.push_back({"outcome=alarm", q([](auto& h) { h.outcome = "alarm"; })});
  out.push_back({"source=mqtt", q([](auto& h) { h.source = "mqtt"; })});
  out.push_back({"step=3", q([](auto& h) { h.step = 3; })});
  out.push_back({"before=<middle id> (paging)", q([n](auto& h) { h.before_id = n / 2; })});
  return out;
}

double percentile(std::vector<double> v, double p) {
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<std::size_t>(p * (v.size() - 1) + 0.5))];
}

// One query as the API runs it: posted to the query thread, waited for.
double timed_query(History& h, const HistoryQuery& q, std::size_t* rows = nullptr,
                   double* cpu = nullptr) {
  std::promise<std::size_t> done;
  auto got = done.get_future();
  const double c = cpu_ms();
  const auto t = Clock::now();
  if (!h.query_async(q, [&](std::vector<MotionRecord> r) { done.set_value(r.size()); }))
    throw std::runtime_error("query refused (503)");
  const std::size_t n = got.get();
  const double wall = ms_since(t);
  if (rows) *rows = n;
  if (cpu) *cpu = cpu_ms() - c;
  return wall;
}

// A handler posted to the I/O thread: from post to run.
double post_delay(asio::io_context& io) {
  std::promise<double> ran;
  auto got = ran.get_future();
  const auto t = Clock::now();
  asio::post(io, [&] { ran.set_value(ms_since(t)); });
  return got.get();
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"lec6_history_queries: the move history's API queries over a large history.db"};
  int64_t records = 100'000;
  int runs = 200;
  std::string dir_arg;
  bool keep = false;
  app.add_option("--records", records, "records in the file")->check(CLI::Range(1000, 10'000'000));
  app.add_option("--runs", runs, "runs per query")->check(CLI::Range(10, 100'000));
  app.add_option("--dir", dir_arg, "state directory (default: a new one in /tmp)");
  app.add_flag("--keep", keep, "keep the file (reused by the next run with --dir)");
  CLI11_PARSE(app, argc, argv);

  std::filesystem::path dir = dir_arg;
  if (dir.empty()) {
    char tmpl[] = "/tmp/lec6-history-queries-XXXXXX";
    dir = mkdtemp(tmpl);
  }
  std::filesystem::create_directories(dir);
  HistoryConfig c;
  c.state_dir = dir;
  c.max_size_mb = 1e6;   // no retention by size in the benchmark
  c.max_age_days = 1e6;  // nor by age
  c.queue = 1 << 20;
  const auto wall = [] { return kT0 + 101 * kDay; };
  {
    History h(c, {"x", "y", "z", "w"}, quiet, wall);
    const int64_t have = h.store().first_free_id() - 1;
    if (have != 0 && have != records) {
      fmt::print(stderr, "{} holds {} records, not {}: give another --dir\n", dir.string(), have,
                 records);
      return 2;
    }
    if (have == 0) {
      const auto t = Clock::now();
      std::mt19937 rng(32);
      for (int64_t i = 0; i < records; ++i) {
        while (h.store().stats().queued > 200'000) std::this_thread::yield();
        h.store().append(motion(i, records, rng), Odometer{});
      }
      h.flush();
      fmt::print("filled {} records in {:.1f} s\n", records, ms_since(t) / 1000);
    }
  }
  History h(c, {"x", "y", "z", "w"}, quiet, wall);
  fmt::print("{}: {} records, {:.1f} MB\n", (dir / "history.db").string(),
             h.store().first_free_id() - 1, h.store().stats().file_bytes / 1e6);
  fmt::print("{:<36} {:>6} {:>8} {:>8} {:>8} {:>9} {:>9}\n", "query (axis x)", "rows", "p50 ms",
             "p99 ms", "max ms", "CPU p50", "CPU p99");
  for (const auto& [name, q] : api_queries(records)) {
    std::vector<double> t, cpu;
    std::size_t rows = 0;
    timed_query(h, q, &rows);  // the first run warms the page cache
    for (int i = 0; i < runs; ++i) {
      double c = 0;
      t.push_back(timed_query(h, q, nullptr, &c));
      cpu.push_back(c);
    }
    fmt::print("{:<36} {:>6} {:>8.2f} {:>8.2f} {:>8.2f} {:>9.2f} {:>9.2f}\n", name, rows,
               percentile(t, 0.5), percentile(t, 0.99), *std::max_element(t.begin(), t.end()),
               percentile(cpu, 0.5), percentile(cpu, 0.99));
  }

  // A stop on the I/O thread while the heaviest query runs on the query thread.
  asio::io_context io;
  auto work = asio::make_work_guard(io);
  std::thread io_thread([&] { io.run(); });
  std::vector<double> idle, during;
  for (int i = 0; i < runs; ++i) idle.push_back(post_delay(io));
  HistoryQuery heavy;
  heavy.axis = "x";
  heavy.limit = 10000;
  int overlapped = 0;
  for (int i = 0; i < runs; ++i) {
    std::promise<void> done;
    auto finished = done.get_future();
    h.query_async(heavy, [&](std::vector<MotionRecord>) { done.set_value(); });
    // Post the stop a little after the query began (it takes milliseconds).
    std::this_thread::sleep_for(std::chrono::microseconds(500 + 37 * (i % 20)));
    during.push_back(post_delay(io));
    if (finished.wait_for(std::chrono::seconds(0)) != std::future_status::ready) ++overlapped;
    finished.wait();
  }
  work.reset();
  io.stop();
  io_thread.join();
  fmt::print(
      "stop handler posted to the I/O thread: idle p50 {:.3f} ms p99 {:.3f} ms; during a "
      "limit=10000 query p50 {:.3f} ms p99 {:.3f} ms ({} of {} posts overlapped a query)\n",
      percentile(idle, 0.5), percentile(idle, 0.99), percentile(during, 0.5),
      percentile(during, 0.99), overlapped, runs);
  if (!keep && dir_arg.empty()) std::filesystem::remove_all(dir);
  return 0;
}
