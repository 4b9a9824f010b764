#pragma once
// `lec sim --trace`: one line per frame, the query as received and the reply
// as sent, each with its time since the server started, in hex and explained
// in the manual's terms.
//
// The bus does not expose the frames it delimits, so the mirror runs a second
// DeviceFramer fed exactly like the bus's (same bytes, same times, same
// silent interval): it sees the same frames at the same instants.
//
// Thread safety: none; used from the event loop's thread only.

#include <cstdint>
#include <functional>
#include <map>
#include <span>
#include <string>

#include "lec6/clock.hpp"
#include "lec6/modbus/framer.hpp"
#include "lec6/modbus/pdu.hpp"

namespace lec6::twin {

class TraceMirror {
 public:
  // `end` as the bus's framer has it (fast timing: LengthOrSilence).
  TraceMirror(Duration silent_interval, modbus::FrameEnd end, TimePoint origin,
              std::function<void(const std::string&)> sink);

  // Bytes given to the bus at `t`; traces the queries they complete.
  void feed(std::span<const uint8_t> bytes, TimePoint t);
  // Traces the queries complete at `t` (the silent interval has passed).
  void poll(TimePoint t);
  // A reply written (or not: nobody to receive it) at `t`.
  void reply(const modbus::Bytes& bytes, TimePoint t, bool delivered);

 private:
  double ms_since_start(TimePoint t) const { return to_ms(t - origin_); }

  modbus::DeviceFramer framer_;
  TimePoint origin_;
  std::function<void(const std::string&)> sink_;
  std::map<uint8_t, modbus::RequestFrame> last_request_;  // by ID: what a reply answers
};

}  // namespace lec6::twin
