// The line simulation (line_sim.hpp) as a test: 2 000 plants by seed (300
// under the sanitizers), every invariant on every run; a run replays exactly
// from its seed. `make soak` runs 10^6 seeds (serve_sim --seeds 0:1000000).

#include <gtest/gtest.h>

#include "sanitized.hpp"
#include "serve/sim/line_sim.hpp"

namespace lec6::serve::sim_testing {
namespace {

constexpr uint64_t kSeeds = testing::sanitized<uint64_t>(2000, 300);

TEST(LineSim, EveryInvariantHoldsInEveryPlant) {
  std::size_t stops = 0;
  for (uint64_t seed = 0; seed < kSeeds; ++seed) {
    const SimRun r = run_line_sim(seed);
    stops += r.stop_wait_ms.size();
    ASSERT_TRUE(r.violations.empty())
        << "seed " << seed << " (" << r.plant << "): " << r.violations.front()
        << "\nreplay: serve_sim --seed " << seed << " --trace";
  }
  EXPECT_GT(stops, kSeeds) << "the plants must stop answering axes, many times";
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
