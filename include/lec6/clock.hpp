#pragma once
// Time as the protocol sees it. Protocol logic never reads a clock by itself:
// it is handed time points, and whoever drives it (a transport, a test) owns
// the clock. Tests use VirtualClock and never sleep.
//
// Thread safety: SteadyClock is safe from any thread. A VirtualClock is not
// synchronised: whoever moves it (a test, the in-process twin link) owns it,
// and its readers run on that thread.

#include <chrono>
#include <cstdint>
#include <type_traits>

#include "lec6/error.hpp"

namespace lec6 {

using Duration = std::chrono::nanoseconds;
using TimePoint = std::chrono::time_point<std::chrono::steady_clock, Duration>;

// Fractional milliseconds and seconds, as people type them (`--timeout 2.5s`)
// or as computations produce them. Whole values need none of this:
// std::chrono::milliseconds(5) converts to Duration exactly.
using FractionalMilliseconds = std::chrono::duration<double, std::milli>;
using FractionalSeconds = std::chrono::duration<double>;

// Any duration as a Duration, rounded to the nearest nanosecond, never
// truncated: to_duration(FractionalMilliseconds(0.29)) is 290 000 ns, where
// a cast of 0.29 × 10⁶ would give 289 999. Throws lec6::InvalidArgument for
// a value that is not a number or beyond ±292 years.
template <class Rep, class Period>
constexpr Duration to_duration(std::chrono::duration<Rep, Period> d) {
  if constexpr (std::is_floating_point_v<Rep>) {
    const long double ns = std::chrono::duration<long double, std::nano>(d).count();
    constexpr long double kLimit = 9.2e18L;  // just inside Duration's ±9.22 × 10¹⁸ ns
    if (!(ns >= -kLimit && ns <= kLimit)) {
      throw InvalidArgument("a duration is not a number or out of range (±292 years)");
    }
  }
  return std::chrono::round<Duration>(d);
}
inline constexpr double to_ms(Duration d) {
  return static_cast<double>(d.count()) / 1e6;
}
inline constexpr double to_seconds(Duration d) {
  return static_cast<double>(d.count()) / 1e9;
}

class Clock {
 public:
  virtual ~Clock() = default;
  virtual TimePoint now() const = 0;
};

// The monotonic wall clock, for programs.
class SteadyClock final : public Clock {
 public:
  TimePoint now() const override {
    return std::chrono::time_point_cast<Duration>(std::chrono::steady_clock::now());
  }
};

// A clock that only moves when told to, for tests and simulations.
class VirtualClock final : public Clock {
 public:
  explicit VirtualClock(TimePoint start = TimePoint{}) : now_(start) {}
  TimePoint now() const override { return now_; }
  void advance(Duration d) { now_ += d; }
  void set(TimePoint t) { now_ = t; }

 private:
  TimePoint now_;
};

}  // namespace lec6
