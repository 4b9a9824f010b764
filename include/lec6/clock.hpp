#pragma once
// Time as the protocol sees it. Protocol logic never reads a clock by itself:
// it is handed time points, and whoever drives it (a transport, a test) owns
// the clock. Tests use VirtualClock and never sleep.

#include <chrono>
#include <cstdint>

namespace lec6 {

using Duration = std::chrono::nanoseconds;
using TimePoint = std::chrono::time_point<std::chrono::steady_clock, Duration>;

inline constexpr Duration milliseconds(double ms) {
  return Duration(static_cast<int64_t>(ms * 1e6));
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
