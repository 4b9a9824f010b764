// The mbap fuzz harness (fuzz/harness_mbap.hpp) in an ordinary test: its
// seeds, every byte flip and cut of them, and every input kept under
// tests/fuzz_regressions/mbap/. Any compiler, no libFuzzer needed.

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "../../fuzz/harness_mbap.hpp"

namespace lec6::fuzz {
namespace {

namespace fs = std::filesystem;

struct ThrowOnFailure {
  ThrowOnFailure() {
    failure_handler() = [](const std::string& what) { throw std::runtime_error(what); };
  }
  ~ThrowOnFailure() { failure_handler() = nullptr; }
};

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
  const fs::path dir = fs::path(LEC6_TEST_DATA_DIR) / ".." / "fuzz_regressions" / "mbap";
  std::size_t n = 0;
  for (const auto& entry : fs::directory_iterator(dir)) {
    if (!entry.is_regular_file() || entry.path().filename() == ".gitkeep") continue;
    std::ifstream in(entry.path(), std::ios::binary);
    modbus::Bytes input((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    run(input, entry.path().filename().string());
    ++n;
  }
  std::printf("mbap regression inputs run: %zu\n", n);
  EXPECT_GE(n, 1u) << "the kept inputs were not found in " << dir;
}

}  // namespace
}  // namespace lec6::fuzz
