// serve_sim: the line simulation (line_sim.hpp) from the command line.
//   serve_sim --seeds 0:100000      every seed of the range; prints failures and the stop waits
//   serve_sim --seed 42 --trace     one run, every event
// Exit 0 when every invariant held.

#include <fmt/format.h>

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "serve/sim/line_sim.hpp"

using lec6::serve::sim_testing::run_line_sim;

int main(int argc, char** argv) {
  uint64_t first = 0, last = 1000;
  bool trace = false;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--seeds" && i + 1 < argc) {
      const std::string v = argv[++i];
      const auto colon = v.find(':');
      if (colon == std::string::npos) {
        fmt::print(stderr, "serve_sim: --seeds FIRST:LAST, e.g. 0:100000\n");
        return 2;
      }
      first = std::strtoull(v.substr(0, colon).c_str(), nullptr, 10);
      last = std::strtoull(v.substr(colon + 1).c_str(), nullptr, 10);
    } else if (a == "--seed" && i + 1 < argc) {
      first = std::strtoull(argv[++i], nullptr, 10);
      last = first + 1;
    } else if (a == "--trace") {
      trace = true;
    } else {
      fmt::print(
          stderr,
          "usage: serve_sim [--seeds FIRST:LAST | --seed N [--trace]]\n"
          "  the deterministic line simulation of lec serve (tests/serve/sim/line_sim.hpp)\n");
      return a == "--help" || a == "-h" ? 0 : 2;
    }
  }
  std::vector<double> waits, operator_waits;
  std::vector<std::pair<double, uint64_t>> worst;  // a seed's longest stop wait
  uint64_t failed = 0;
  std::size_t jobs = 0, stops = 0;
  std::size_t cache_at_submit = 0, cache_at_turn = 0, forgets = 0, forgetting = 0, jogs = 0;
  for (uint64_t seed = first; seed < last; ++seed) {
    const auto r = run_line_sim(seed, trace);
    if (trace) fmt::print("{}\n{}", r.plant, r.trace);
    waits.insert(waits.end(), r.stop_wait_ms.begin(), r.stop_wait_ms.end());
    operator_waits.insert(operator_waits.end(), r.operator_stop_wait_ms.begin(),
                          r.operator_stop_wait_ms.end());
    if (!r.stop_wait_ms.empty())
      worst.emplace_back(*std::max_element(r.stop_wait_ms.begin(), r.stop_wait_ms.end()), seed);
    jobs += r.jobs;
    stops += r.stops;
    cache_at_submit += r.cache_at_submit;
    cache_at_turn += r.cache_at_turn;
    forgets += r.forgets;
    forgetting += r.forgets > 0;
    jogs += r.jog_sources;
    if (!r.violations.empty()) {
      ++failed;
      fmt::print("seed {} FAILED ({}): {}\n  replay: serve_sim --seed {} --trace\n", seed, r.plant,
                 r.violations.front(), seed);
    }
  }
  std::sort(waits.begin(), waits.end());
  std::sort(operator_waits.begin(), operator_waits.end());
  const auto at = [](const std::vector<double>& w, double q) {
    return w.empty() ? 0.0 : w[std::min(w.size() - 1, static_cast<std::size_t>(q * w.size()))];
  };
  fmt::print(
      "{} passed, {} failed; {} jobs, {} stops; stop to the wire (answering controllers, "
      "{} stops): p50 {:.1f} ms, p99 {:.1f} ms, max {:.1f} ms\n",
      last - first - failed, failed, jobs, stops, waits.size(), at(waits, 0.5), at(waits, 0.99),
      waits.empty() ? 0.0 : waits.back());
  fmt::print(
      "the operators' RESET and HOLD among them ({} stops): p50 {:.1f} ms, p99 {:.1f} ms, max "
      "{:.1f} ms\n",
      operator_waits.size(), at(operator_waits, 0.5), at(operator_waits, 0.99),
      operator_waits.empty() ? 0.0 : operator_waits.back());
  fmt::print(
      "command turns: {} reads answered from the cache at submit, {} when their turn came; idle "
      "sources forgotten {} times in {} plants; {} jogs on the wire, each its own source\n",
      cache_at_submit, cache_at_turn, forgets, forgetting, jogs);
  std::sort(worst.rbegin(), worst.rend());
  if (!trace && !worst.empty()) {
    fmt::print("longest waits:");
    for (std::size_t i = 0; i < std::min<std::size_t>(5, worst.size()); ++i)
      fmt::print(" seed {} ({:.0f} ms)", worst[i].second, worst[i].first);
    fmt::print("\n");
  }
  return failed == 0 ? 0 : 1;
}
