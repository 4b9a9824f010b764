#pragma once
// A Link to a twin bus in the same process: `--port sim`, `lec demo`, and the
// client's tests. Bytes take their wire time and replies come when the twin's
// timing says, on whichever clock it is given:
//  - a VirtualClock: waiting jumps the clock (tests run in no wall time);
//  - the SteadyClock: waiting sleeps (a person watching sees real motion).
//
// Thread safety: one thread at a time, the same one that uses its Bus and clock.

#include <deque>

#include "lec6/client/link.hpp"
#include "lec6/sim/bus.hpp"

namespace lec6::twin {

class SimLink final : public client::Link {
 public:
  SimLink(sim::Bus& bus, VirtualClock& clock);
  SimLink(sim::Bus& bus, const SteadyClock& clock);

  void write(std::span<const uint8_t> bytes) override;
  std::size_t read_some(std::span<uint8_t> buffer, TimePoint deadline) override;
  void discard_input() override;
  const Clock& clock() const override { return clock_; }
  uint32_t baud() const override { return bus_.line().line.baud; }
  std::string describe() const override;

 private:
  struct Arrival {
    TimePoint at;  // the last byte is in
    modbus::Bytes bytes;
  };
  // Moves the clock (virtual) or sleeps (wall) until `t`.
  void wait_until(TimePoint t);
  void collect_replies();

  sim::Bus& bus_;
  const Clock& clock_;
  VirtualClock* virtual_ = nullptr;
  std::deque<Arrival> incoming_;
};

}  // namespace lec6::twin
