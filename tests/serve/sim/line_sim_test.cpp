// The line simulation (line_sim.hpp) as a test: 2 000 plants by seed (300
// under the sanitizers), every invariant on every run; a run replays exactly
// from its seed. `make soak` runs 10^6 seeds (serve_sim --seeds 0:1000000).

#include <gtest/gtest.h>

#include <string>

#include "sanitized.hpp"
#include "serve/sim/line_sim.hpp"

namespace lec6::serve::sim_testing {
namespace {

constexpr uint64_t kSeeds = testing::sanitized<uint64_t>(2000, 300);

// The plants also reach the command turns' rarer paths (counted from what
// the scheduler did, in the same runs: a second pass would double the time):
// reads answered from the cache when their turn came, the forgetting of idle
// sources, jogs each under a source of their own.
TEST(LineSim, EveryInvariantHoldsInEveryPlant) {
  std::size_t stops = 0, cache_at_turn = 0, forgets = 0, jog_sources = 0;
  uint64_t cache_hits = 0;
  for (uint64_t seed = 0; seed < kSeeds; ++seed) {
    const SimRun r = run_line_sim(seed);
    stops += r.stop_wait_ms.size();
    cache_at_turn += r.cache_at_turn;
    cache_hits += r.cache_hits;
    forgets += r.forgets;
    jog_sources += r.jog_sources;
    ASSERT_TRUE(r.violations.empty())
        << "seed " << seed << " (" << r.plant << "): " << r.violations.front()
        << "\nreplay: serve_sim --seed " << seed << " --trace";
  }
  EXPECT_GT(stops, kSeeds) << "the plants must stop answering axes, many times";
  EXPECT_GT(cache_at_turn, kSeeds) << "reads answered from the cache when their turn came";
  EXPECT_GT(cache_hits, cache_at_turn) << "and at their submit";
  EXPECT_GT(forgets, kSeeds / 20) << "the scheduler must forget idle sources, in many plants";
  EXPECT_GT(jog_sources, kSeeds) << "jogs on the wire, each its own source";
  RecordProperty("cache_at_turn", std::to_string(cache_at_turn));
  RecordProperty("cache_hits", std::to_string(cache_hits));
  RecordProperty("forgets", std::to_string(forgets));
  RecordProperty("jog_sources", std::to_string(jog_sources));
}

TEST(LineSim, ARunReplaysExactlyFromItsSeed) {
  for (uint64_t seed : {1ULL, 77ULL, 123456ULL}) {
    const SimRun a = run_line_sim(seed, true);
    const SimRun b = run_line_sim(seed, true);
    EXPECT_EQ(a.hash, b.hash) << "seed " << seed;
    EXPECT_EQ(a.trace, b.trace) << "seed " << seed;
    EXPECT_NE(a.hash, run_line_sim(seed + 1).hash);
  }
}

}  // namespace
}  // namespace lec6::serve::sim_testing
