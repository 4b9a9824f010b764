#pragma once
// How a USB serial adapter hands received bytes to the computer, sans-I/O.
//
// An FTDI-style adapter does not pass on each byte as it arrives: it buffers
// them and sends a USB packet when its latency timer expires (16 ms by
// default) or when the packet is full (62 bytes of data on an FT232R). So the
// reader sees bytes in lumps, at latency-timer boundaries, and the silent
// gaps between frames disappear. `lec sim --usb-latency` and `--tap-latency`
// give the twin's ptys this behaviour.
//
// Model: the timer ticks at origin + k × latency. Bytes that arrived by a tick
// are delivered at that tick, in one lump; a lump that reaches `packet_bytes`
// is delivered at once, at the arrival of its last byte. Latency zero
// delivers every push at its arrival time, as pushed.
//
// Thread safety: one thread at a time.

#include <cstddef>
#include <deque>
#include <optional>
#include <span>
#include <vector>

#include "lec6/clock.hpp"
#include "lec6/modbus/pdu.hpp"

namespace lec6::sim {

class UsbLatency {
 public:
  static constexpr std::size_t kFtdiPacketBytes = 62;

  struct Delivery {
    TimePoint at;
    modbus::Bytes bytes;
  };

  explicit UsbLatency(Duration latency, std::size_t packet_bytes = kFtdiPacketBytes,
                      TimePoint origin = TimePoint{});

  // Bytes whose last one arrived at `arrival`. Arrivals must not go back in
  // time (an earlier one is taken as arriving with the previous push).
  void push(std::span<const uint8_t> bytes, TimePoint arrival);

  // The deliveries due by `now`, in order.
  std::vector<Delivery> take(TimePoint now);

  // When the next delivery is due (nullopt: nothing buffered).
  std::optional<TimePoint> next_delivery() const;

  Duration latency() const noexcept { return latency_; }

  // The first timer tick at or after `t` (latency > 0).
  TimePoint tick_after(TimePoint t) const;

 private:
  void seal();

  Duration latency_;
  std::size_t packet_bytes_;
  TimePoint origin_;
  TimePoint last_arrival_{};
  modbus::Bytes open_;                // the lump the adapter is filling
  std::optional<TimePoint> open_due_;  // its timer tick
  std::deque<Delivery> sealed_;       // full or due lumps, in order
};

}  // namespace lec6::sim
