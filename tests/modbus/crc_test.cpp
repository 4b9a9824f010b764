#include "lec6/modbus/crc.hpp"

#include <gtest/gtest.h>

#include <random>
#include <vector>

#include "golden_frames.hpp"

namespace lec6::modbus {
namespace {

constexpr uint8_t kManualExample[] = {0x20, 0x08, 0x00, 0x00, 0x5A, 0xA5};
static_assert(crc16(kManualExample) == 0x611C, "manual §11 worked example, usable at compile time");

TEST(Crc, ManualWorkedExample) {
  EXPECT_EQ(crc16(kManualExample), 0x611C);
  EXPECT_EQ(crc16_bitwise(kManualExample), 0x611C);
  const uint8_t sent[] = {0x20, 0x08, 0x00, 0x00, 0x5A, 0xA5, 0x1C, 0x61};  // low byte first
  EXPECT_TRUE(crc_ok(sent));
}

TEST(Crc, TableMatchesBitwiseDefinitionOnRandomData) {
  std::mt19937 rng(12345);
  for (int n = 0; n < 2000; ++n) {
    std::vector<uint8_t> data(rng() % 300);
    for (auto& b : data) b = static_cast<uint8_t>(rng());
    ASSERT_EQ(crc16(data), crc16_bitwise(data)) << "length " << data.size();
  }
}

TEST(Crc, EveryGoldenFrameCarriesItsCrc) {
  const auto frames = testing::load_golden_frames();
  ASSERT_EQ(frames.size(), 16u);
  for (const auto& g : frames) EXPECT_TRUE(crc_ok(g.bytes)) << g.section << " " << g.meaning;
}

TEST(Crc, AnySingleBitFlipIsDetected) {
  const auto frames = testing::load_golden_frames();
  for (const auto& g : frames) {
    for (std::size_t bit = 0; bit < g.bytes.size() * 8; ++bit) {
      auto copy = g.bytes;
      copy[bit / 8] = static_cast<uint8_t>(copy[bit / 8] ^ (1U << (bit % 8)));
      EXPECT_FALSE(crc_ok(copy)) << g.section << " bit " << bit;
    }
  }
}

TEST(Crc, EmptyAndTinyInputs) {
  EXPECT_EQ(crc16({}), 0xFFFF);
  EXPECT_FALSE(crc_ok({}));
  const uint8_t two[] = {0xFF, 0xFF};
  EXPECT_FALSE(crc_ok(two));
}

}  // namespace
}  // namespace lec6::modbus
