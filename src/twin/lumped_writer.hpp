#pragma once
// Bytes on their way to a pty at the instants a USB adapter would hand them
// over (sim::UsbLatency): the twin's tap (`lec sim --tap`, `--tap-latency`)
// and its master pty with `--usb-latency`.
//
// put() stages bytes with the time their last bit is on the line (which may
// be in the future: the twin computes line times ahead); flush(now) writes
// what is due. With latency zero each put() is written as one piece at its
// time; otherwise each byte is given its own line time (one character time
// apart) and the bytes go out in lumps at latency-timer ticks.
//
// Thread safety: the event loop's thread only.

#include <map>
#include <optional>
#include <span>

#include "lec6/clock.hpp"
#include "lec6/modbus/pdu.hpp"
#include "lec6/sim/usb_latency.hpp"

namespace lec6::twin {

class LumpedWriter {
 public:
  LumpedWriter(int fd, Duration latency, Duration char_time, TimePoint origin);

  void put(std::span<const uint8_t> bytes, TimePoint last_byte);

  // Writes what is due by `now`. Returns false if the pty would not take it
  // all (nobody reads it): those bytes are dropped, as a line drops them.
  bool flush(TimePoint now);

  // When flush() must next run (nullopt: nothing staged).
  std::optional<TimePoint> deadline() const;

  uint64_t bytes_dropped() const noexcept { return dropped_; }

 private:
  int fd_;
  Duration char_time_;
  sim::UsbLatency usb_;
  std::multimap<TimePoint, modbus::Bytes> staged_;  // not yet on the line
  uint64_t dropped_ = 0;
};

}  // namespace lec6::twin
