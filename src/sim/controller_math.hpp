#pragma once
// Numeric helpers shared by the twin controller's source files
// (controller.cpp, controller_operations.cpp).

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

namespace lec6::sim::detail {

// Positions and speeds closer than this are equal (mm, mm/s).
inline constexpr double kEps = 1e-9;

inline uint16_t clamp_u16(double v) {
  if (!(v > 0.0)) return 0;
  if (v >= 65535.0) return 65535;
  return static_cast<uint16_t>(std::llround(v));
}

inline int32_t clamp_i32(int64_t v) {
  return static_cast<int32_t>(std::clamp<int64_t>(v, std::numeric_limits<int32_t>::min(),
                                                  std::numeric_limits<int32_t>::max()));
}

inline int sign_of(double v) {
  return v > 0.0 ? 1 : (v < 0.0 ? -1 : 0);
}

}  // namespace lec6::sim::detail
