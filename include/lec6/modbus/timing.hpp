#pragma once
// Line timing of digest §1 (manual §8.2–8.4). One character is 10 bits (8N1).
//
// Thread safety: value types and pure functions; const objects may be shared between threads,
// writes need the caller's synchronisation.

#include <cstddef>
#include <cstdint>

#include "lec6/clock.hpp"

namespace lec6::modbus {

inline constexpr uint32_t kBaudRates[] = {9600, 19200, 38400, 57600, 115200, 230400};
inline constexpr uint32_t kDefaultBaud = 38400;
inline constexpr int kBitsPerChar = 10;

bool is_supported_baud(uint32_t baud) noexcept;

struct LineTiming {
  uint32_t baud = kDefaultBaud;
  unsigned silent_interval_k = 1;  // controller parameter "Silent INT" (multiples of 3.5 chars)
  Duration delay_td = std::chrono::milliseconds(5);  // controller parameter "Min Resp delay"

  // The controller's internal processing time T0 (manual §8.4: 4 ms). The
  // manual's ×1.5 safety factor is the master's margin, applied in response_time().
  static constexpr Duration kProcessing = std::chrono::milliseconds(4);
  static constexpr double kProcessingSafetyFactor = 1.5;

  Duration char_time() const noexcept { return wire_time(1); }
  Duration wire_time(std::size_t bytes) const noexcept {
    return Duration(static_cast<int64_t>(bytes) * kBitsPerChar * 1'000'000'000LL / baud);
  }
  // Ts = k × 3.5 characters.
  Duration silent_interval() const noexcept {
    return Duration(static_cast<int64_t>(silent_interval_k) * 35 * kBitsPerChar * 100'000'000LL /
                    baud);
  }
  // Tx of manual §8.4: end of query → end of reply, with T0 = 4 ms × 1.5.
  Duration response_time(std::size_t reply_bytes) const noexcept {
    return silent_interval() +
           Duration(static_cast<int64_t>(kProcessing.count() * kProcessingSafetyFactor)) +
           delay_td + wire_time(reply_bytes);
  }
  // When the twin's reply ends after the end of a query: Ts + 4 ms + Td + wire.
  Duration nominal_turnaround(std::size_t reply_bytes) const noexcept {
    return silent_interval() + kProcessing + delay_td + wire_time(reply_bytes);
  }
  // The fastest one transaction can be (digest §1, "the limit").
  Duration transaction_limit(std::size_t query_bytes, std::size_t reply_bytes) const noexcept {
    return wire_time(query_bytes) + nominal_turnaround(reply_bytes);
  }
};

}  // namespace lec6::modbus
