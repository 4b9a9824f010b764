#pragma once
// Lengths travel as integers in 0.01 mm; people type and read millimetres
// with up to two decimals. These are the only conversions between the two.
//
// Thread safety: pure functions.

#include <cstdint>
#include <string>
#include <string_view>

#include "lec6/expected.hpp"

namespace lec6::lec {

// "150.00" for 15000. Always two decimals, sign only when negative.
std::string format_mm(int64_t position_001mm);

// "150", "150.5", "-0.25", "+3.10" → 0.01 mm. Refuses more than two decimals,
// text that is not a number, and values outside ±2147483647 (0.01 mm).
Expected<int64_t, std::string> parse_mm(std::string_view text);

// A whole number, e.g. "500". Refuses fractions and junk.
Expected<int64_t, std::string> parse_integer(std::string_view text);

}  // namespace lec6::lec
