// The move history's durations against the twin's true BUSY time, with 1, 4
// and 8 axes moving on one line (issue 32: BENCHMARKS.md, "Move history").
//
// In process, wired as `lec serve` wires it (daemon.cpp start_history): a
// Line on the built-in twin in real timing (38400 baud unless told), the
// Operations that run HTTP's moves, and one MotionTracker per axis fed by
// the operations' events and the line's telemetry reads. Every axis moves
// back and forth between two targets at once; each record's duration (BUSY's
// rise to its fall, bracketed by the polls) is compared with the twin's own
// record of that operation (sim::OperationRecord: when BUSY rose and fell).
//
// Reported per load: records, those with a duration, the error's p50 / p95 /
// max and its mean with its sign (a bias), how many lie within their stated
// ±, the ± itself, when the operation's polls first saw BUSY, and how many
// the drift detector would judge (± ≤ max_uncertainty_fraction × threshold
// × duration: DriftConfig's defaults).
//
// Usage: lec6_history_timing [--axes 1,4,8] [--moves 12] [--baud 38400] [--stagger-ms 0]

#include <fmt/format.h>
#include <CLI/CLI.hpp>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <future>
#include <mutex>
#include <random>
#include <thread>
#include <vector>

#include "history/drift.hpp"
#include "history/tracker.hpp"
#include "lec6/sim/bus.hpp"
#include "line/line.hpp"
#include "line/wire.hpp"
#include "ops/commands.hpp"
#include "ops/operations.hpp"

namespace {

using namespace lec6;
using namespace lec6::serve;

struct Row {
  int axes = 0;
  std::size_t records = 0, timed = 0, within = 0, judged = 0, by_positions = 0;
  std::vector<double> error_ms, pm_ms, signed_ms, up_ms;
};

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return NAN;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<std::size_t>(p * static_cast<double>(v.size())))];
}

OpResult run(Operations& ops, const AxisRef& axis, std::string_view op, nlohmann::json args) {
  auto cmd = parse_command(op, args);
  if (!cmd) throw std::runtime_error(fmt::format("{}: {}", op, cmd.error().message));
  std::promise<OpResult> done;
  auto f = done.get_future();
  ops.run(axis, *cmd, "bench", [&done](OpResult r) { done.set_value(std::move(r)); });
  return f.get();
}

Row measure(int n_axes, int moves, uint32_t baud, int stagger_ms) {
  LineConfig lc;
  lc.name = "line1";
  lc.port = "sim";
  lc.baud = baud;
  lc.sim.fast = false;  // real timing: the line's load is what widens the brackets
  for (int id = 1; id <= n_axes; ++id) {
    AxisConfig a;
    a.id = static_cast<uint8_t>(id);
    a.name = fmt::format("axis{}", id);
    lc.axes.push_back(a);  // telemetry at the default 10 Hz, as shipped
  }
  LineOptions o;
  o.name = lc.name;
  o.port = lc.port;
  o.scheduler = scheduler_config(lc);
  const SteadyClock clock;
  Line line(
      o, [&lc] { return open_wire(lc); }, clock);
  std::vector<AxisRef> axes;
  for (const AxisConfig& a : lc.axes) axes.push_back(AxisRef{a.name, a.id, &line, &lc, &a});

  std::mutex mutex;
  std::vector<history::MotionTracker> trackers;
  std::vector<std::vector<history::MotionRecord>> records(static_cast<std::size_t>(n_axes));
  for (const AxisRef& a : axes) trackers.emplace_back(a.name);
  const auto keep = [&](std::size_t i, std::optional<history::MotionRecord> r) {
    if (r && r->kind == "move") records[i].push_back(std::move(*r));
  };
  Operations ops([](LogLevel, std::string_view) {});
  ops.add_observer([&](const std::string& axis, const nlohmann::json& event) {
    const std::size_t i = std::stoul(axis.substr(4)) - 1;
    std::lock_guard lock(mutex);
    keep(i, trackers[i].op_event(event, clock.now(), 0));
  });
  line.add_observer([&](const TelemetryEvent& e, const AxisSnapshot& s) {
    if (e.block != Block::State && e.block != Block::Flags) return;
    AxisSnapshot read;
    if (e.block == Block::State) read.state = s.state;
    if (e.block == Block::Flags) read.flags = s.flags;
    const std::size_t i = e.id - 1U;
    std::lock_guard lock(mutex);
    keep(i,
         trackers[i].telemetry(read.state, read.flags, e.at, 0,
                               e.started == TimePoint{} ? std::nullopt : std::optional(e.started)));
  });
  line.start();

  for (const AxisRef& a : axes) {
    for (const auto& [op, args] : std::vector<std::pair<std::string, nlohmann::json>>{
             {"serial", {{"on", true}}}, {"servo", {{"on", true}}}, {"home", {}}}) {
      const OpResult r = run(ops, a, op, args.is_null() ? nlohmann::json::object() : args);
      if (r.status != 200)
        throw std::runtime_error(fmt::format("{} {}: {}", a.name, op, r.body.dump()));
    }
  }
  // Every axis back and forth at once: 200 mm at 100 mm/s, about 2 s a move.
  std::vector<std::thread> movers;
  for (const AxisRef& a : axes) {
    movers.emplace_back([&, a] {
      // --stagger-ms: each move waits a random 0..N ms first, so that the axes
      // do not move in lockstep (0: all at once, the same move every time).
      std::mt19937 rng(a.id);
      std::uniform_int_distribution<int> pause(0, std::max(0, stagger_ms));
      for (int i = 0; i < moves; ++i) {
        if (stagger_ms > 0) std::this_thread::sleep_for(std::chrono::milliseconds(pause(rng)));
        const OpResult r =
            run(ops, a, "move", {{"position_mm", i % 2 == 0 ? 250 : 50}, {"speed_mm_s", 100}});
        if (r.status != 200) fmt::print(stderr, "{}: {}\n", a.name, r.body.dump());
      }
    });
  }
  for (auto& t : movers) t.join();

  // The twin's truth: each axis' operations after its homing.
  std::promise<std::vector<std::vector<sim::OperationRecord>>> truth_p;
  line.post_twin([&](sim::Bus* bus, TimePoint) {
    std::vector<std::vector<sim::OperationRecord>> all;
    for (const AxisRef& a : axes) {
      std::vector<sim::OperationRecord> mine;
      for (const auto& op : bus->find(a.id)->operations())
        if (!op.homing && op.busy_rose && op.busy_fell) mine.push_back(op);
      all.push_back(std::move(mine));
    }
    truth_p.set_value(std::move(all));
  });
  const auto truth = truth_p.get_future().get();
  ops.shutdown();
  line.stop();
  ops.shutdown();

  Row row;
  row.axes = n_axes;
  const history::DriftConfig drift;
  std::lock_guard lock(mutex);
  for (std::size_t i = 0; i < records.size(); ++i) {
    const auto& recs = records[i];
    const auto& ops_true = truth[i];
    // The last `moves` of each: the tracker's records and the twin's in order.
    const std::size_t n = std::min(recs.size(), ops_true.size());
    for (std::size_t k = 0; k < n; ++k) {
      const auto& r = recs[recs.size() - n + k];
      const auto& t = ops_true[ops_true.size() - n + k];
      ++row.records;
      if (std::isnan(r.duration_s) || !r.duration_pm_s) continue;
      ++row.timed;
      if (r.timed_by == "positions") ++row.by_positions;
      const double true_s = to_seconds(*t.busy_fell - *t.busy_rose);
      const double err = std::abs(r.duration_s - true_s);
      row.error_ms.push_back(err * 1000);
      row.signed_ms.push_back((r.duration_s - true_s) * 1000);
      if (std::getenv("LEC6_BENCH_VERBOSE"))
        fmt::print(
            stderr,
            "{} axes, axis {}: up {:.1f} down {:.1f} ms, duration {:.1f} ± {:.1f} ({}), true "
            "{:.1f}\n",
            n_axes, i + 1, r.busy_up_s.value_or(NAN) * 1000, r.busy_down_s.value_or(NAN) * 1000,
            r.duration_s * 1000, *r.duration_pm_s * 1000, r.timed_by, true_s * 1000);
      if (r.busy_up_s) row.up_ms.push_back(*r.busy_up_s * 1000);
      row.pm_ms.push_back(*r.duration_pm_s * 1000);
      if (err <= *r.duration_pm_s + 1e-6) ++row.within;
      if (*r.duration_pm_s <= drift.max_uncertainty_fraction * drift.threshold * r.duration_s)
        ++row.judged;
    }
  }
  return row;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"The move history's durations against the twin's true BUSY time under load"};
  std::vector<int> loads{1, 4, 8};
  int moves = 12;
  int stagger_ms = 0;
  uint32_t baud = 38400;
  app.add_option("--axes", loads, "moving axes per run")->delimiter(',');
  app.add_option("--moves", moves, "moves per axis per run")->check(CLI::Range(2, 10000));
  app.add_option("--stagger-ms", stagger_ms, "each move waits a random 0..N ms first (0: lockstep)")
      ->check(CLI::Range(0, 10000));
  app.add_option("--baud", baud, "the line's baud rate");
  CLI11_PARSE(app, argc, argv);
  fmt::print(
      "| moving axes | moves recorded | with a duration | timed by positions | error p50 / p95 / "
      "max | mean signed error | "
      "within its ± | ± p50 / max | BUSY first seen after the start, p50 | judged by the drift "
      "detector |\n|---|---|---|---|---|---|---|---|---|---|\n");
  for (const int n : loads) {
    const Row r = measure(n, moves, baud, stagger_ms);
    double bias = 0;
    for (double e : r.signed_ms) bias += e / double(r.signed_ms.size());
    fmt::print(
        "| {} | {} | {} | {} | {:.1f} / {:.1f} / {:.1f} ms | {:+.1f} ms | {} of {} | {:.1f} / "
        "{:.1f} ms "
        "| {:.1f} ms | {} of {} |\n",
        r.axes, r.records, r.timed, r.by_positions, percentile(r.error_ms, 0.5),
        percentile(r.error_ms, 0.95), percentile(r.error_ms, 1.0), bias, r.within, r.timed,
        percentile(r.pm_ms, 0.5), percentile(r.pm_ms, 1.0), percentile(r.up_ms, 0.5), r.judged,
        r.timed);
    std::fflush(stdout);
  }
  return 0;
}
