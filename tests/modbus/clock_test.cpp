// Durations from fractional milliseconds and seconds round to the nearest
// nanosecond (lec6/clock.hpp); they used to be truncated.

#include <cmath>
#include <limits>

#include <gtest/gtest.h>

#include "lec6/clock.hpp"

namespace lec6 {
namespace {

using std::chrono::nanoseconds;

TEST(Duration, FractionalMillisecondsRoundToTheNearestNanosecond) {
  // 0.29 ms is 289 999.999… ns in binary floating point: truncation gave 289 999.
  EXPECT_EQ(to_duration(FractionalMilliseconds(0.29)), nanoseconds(290'000));
  EXPECT_EQ(to_duration(FractionalMilliseconds(0.0000014)), nanoseconds(1));
  EXPECT_EQ(to_duration(FractionalMilliseconds(0.0000016)), nanoseconds(2));
  EXPECT_EQ(to_duration(FractionalMilliseconds(-0.29)), nanoseconds(-290'000));
  EXPECT_EQ(to_duration(FractionalSeconds(1.5)), std::chrono::milliseconds(1500));
  EXPECT_EQ(to_duration(FractionalSeconds(0.1 * 3)), std::chrono::milliseconds(300));
}

TEST(Duration, WholeUnitsConvertExactly) {
  EXPECT_EQ(to_duration(std::chrono::milliseconds(5)), nanoseconds(5'000'000));
  EXPECT_EQ(to_duration(std::chrono::seconds(2)), nanoseconds(2'000'000'000));
  static_assert(to_duration(FractionalMilliseconds(4.0)) == std::chrono::milliseconds(4));
}

TEST(Duration, NotANumberOrOutOfRangeIsRefused) {
  EXPECT_THROW((void)to_duration(FractionalMilliseconds(std::nan(""))), InvalidArgument);
  EXPECT_THROW((void)to_duration(FractionalSeconds(std::numeric_limits<double>::infinity())),
               InvalidArgument);
  EXPECT_THROW((void)to_duration(FractionalSeconds(1e12)), InvalidArgument);  // 31 700 years
  EXPECT_NO_THROW((void)to_duration(FractionalSeconds(9e9)));                 // 285 years
}

}  // namespace
}  // namespace lec6
