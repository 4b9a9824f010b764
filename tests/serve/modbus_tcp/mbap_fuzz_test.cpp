// The mbap fuzz harness (fuzz/harness_mbap.hpp) in an ordinary test: its
// seeds, every byte flip and cut of them, and every input kept under
// tests/fuzz_regressions/mbap/. Any compiler, no libFuzzer needed.

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "../../../fuzz/harness_mbap.hpp"
#include "serve/fuzz_replay.hpp"

namespace lec6::fuzz {
namespace {

namespace fs = std::filesystem;

void run(const modbus::Bytes& input, const std::string& label) {
  ThrowOnFailure guard;
  try {
    mbap_one(input.data(), input.size());
  } catch (const std::exception& e) {
    ADD_FAILURE() << "mbap harness, input " << label << ": " << e.what();
  }
}

std::vector<Seed> seeds() {
  std::ifstream in(fs::path(LEC6_TEST_DATA_DIR) / "manual-frames.tsv");
  std::stringstream text;
  text << in.rdbuf();
  return mbap_seeds(text.str());
}

TEST(MbapFuzzHarness, SeedsPass) {
  const auto all = seeds();
  ASSERT_GE(all.size(), 20u);
  for (const auto& [name, input] : all) run(input, name);
}

TEST(MbapFuzzHarness, EveryByteFlipAndCutOfTheSeedsPasses) {
  std::size_t runs = 0;
  for (const auto& [name, input] : seeds()) {
    for (std::size_t i = 1; i < input.size(); ++i) {
      modbus::Bytes flipped = input;
      flipped[i] ^= 0x41;
      run(flipped, name + " flip " + std::to_string(i));
      run(modbus::Bytes(input.begin(), input.begin() + static_cast<std::ptrdiff_t>(i)),
          name + " cut " + std::to_string(i));
      runs += 2;
      if (::testing::Test::HasFailure()) return;
    }
  }
  EXPECT_GT(runs, 500u);
}

TEST(MbapFuzzHarness, KeptRegressionInputsPass) {
  std::size_t n = 0;
  for (const auto& [name, bytes] : kept_inputs("mbap")) {
    run(modbus::Bytes(bytes.begin(), bytes.end()), name);
    ++n;
  }
  std::printf("mbap regression inputs run: %zu\n", n);
  EXPECT_GE(n, 1u) << "no kept input found under tests/fuzz_regressions/mbap";
}

}  // namespace
}  // namespace lec6::fuzz
