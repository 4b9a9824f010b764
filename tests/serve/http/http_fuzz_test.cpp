// The http fuzz harness (fuzz/harness_http.hpp) in an ordinary test: its
// seeds, every byte flip and cut of them, and every input kept under
// tests/fuzz_regressions/http/. Any compiler, no libFuzzer needed.

#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "../../../fuzz/harness_http.hpp"
#include "../../../fuzz/seeds_http.hpp"
#include "serve/fuzz_replay.hpp"

namespace lec6::fuzz {
namespace {

namespace fs = std::filesystem;

void run(const std::string& input, const std::string& label) {
  ThrowOnFailure guard;
  try {
    http_one(reinterpret_cast<const uint8_t*>(input.data()), input.size());
  } catch (const std::exception& e) {
    ADD_FAILURE() << "http harness, input " << label << ": " << e.what();
  }
}

TEST(HttpFuzzHarness, SeedsPass) {
  const auto seeds = http_seeds();
  ASSERT_GE(seeds.size(), 10u);
  for (const auto& [name, input] : seeds) run(input, name);
}

TEST(HttpFuzzHarness, EveryByteFlipAndCutOfTheSeedsPasses) {
  std::size_t runs = 0;
  for (const auto& [name, input] : http_seeds()) {
    for (std::size_t i = 1; i < input.size(); ++i) {
      std::string flipped = input;
      flipped[i] = static_cast<char>(flipped[i] ^ 0x41);
      run(flipped, name + " flip " + std::to_string(i));
      run(input.substr(0, i), name + " cut " + std::to_string(i));
      runs += 2;
      if (::testing::Test::HasFailure()) return;
    }
  }
  EXPECT_GT(runs, 1000u);
}

TEST(HttpFuzzHarness, KeptRegressionInputsPass) {
  std::size_t n = 0;
  for (const auto& [name, input] : kept_inputs("http")) {
    run(input, name);
    ++n;
  }
  // No skip: with no kept input it runs none and says so (the CI log shows the count).
  std::printf("fuzz regression replay: %zu kept input(s) of harness 'http' run%s\n", n,
              n == 0 ? " (none kept)" : "");
}

// The harness notices what it is meant to notice.
TEST(HttpFuzzHarness, ItsPropertiesCanFail) {
  ThrowOnFailure guard;
  EXPECT_THROW(http_detail::check_request(serve::HttpRequest{}, serve::HttpLimits{}),
               std::runtime_error);
}

}  // namespace
}  // namespace lec6::fuzz
