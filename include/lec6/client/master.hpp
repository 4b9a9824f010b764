#pragma once
// Who carries one request to a controller and brings its reply back. The
// Client builds typed reads, writes and retries on top of a Master; the
// Master knows the wire:
//
//   - RtuMaster: Modbus RTU over any byte Link (serial, RTU over TCP, the
//     in-process twin), with the manual's timing (rtu_master.hpp);
//   - transport::ModbusTcpMaster: Modbus TCP (MBAP), e.g. through `lec serve`;
//   - lec serve's scheduled master, which queues the exchange on its line.
//
// Thread safety: a Master is used by one thread at a time unless the
// implementation says otherwise.

#include <cstdint>
#include <functional>
#include <optional>
#include <span>
#include <string>

#include "lec6/client/link.hpp"
#include "lec6/clock.hpp"
#include "lec6/modbus/pdu.hpp"
#include "lec6/modbus/timing.hpp"

namespace lec6::client {

// Counters for a session: what the line did.
struct LinkStats {
  uint64_t transactions = 0;
  uint64_t retries = 0;
  uint64_t timeouts = 0;
  uint64_t crc_errors = 0;
  uint64_t framing_errors = 0;
  uint64_t exceptions = 0;
  uint64_t bytes_discarded = 0;  // stray bytes dropped: noise, late replies
  // How long this master held the line: each exchange from its request's
  // first byte to its reply's last (or until it was given up). 0 where the
  // master does not see the wire (Modbus TCP): then it is not known.
  Duration busy{};
};

// One frame on its way out or in, for `--trace`.
struct TraceEvent {
  bool outgoing;  // true: sent, false: received
  TimePoint at;
  std::span<const uint8_t> bytes;  // as they travel (RTU with CRC, or MBAP)
  std::string explanation;         // in LEC terms
};
using TraceSink = std::function<void(const TraceEvent&)>;

// When an exchange was on the wire (issue 32): its request's first byte was
// written at `sent` and its reply's last byte read at `replied`, on the
// master's clock. What the reply shows was sampled between the two, however
// long the reply then took to reach the thread that asked.
struct WireTimes {
  TimePoint sent{};
  TimePoint replied{};
};

class Master {
 public:
  virtual ~Master() = default;

  // One exchange, no retries, no address checks. Returns the verified reply;
  // an exception reply is returned, not thrown. A broadcast (ID 0) returns
  // once the line is free again, with an empty WriteMultipleResponse.
  // Throws TransportError (and Cancelled when the wait was interrupted).
  virtual modbus::ResponseFrame exchange(const modbus::RequestFrame& frame) = 0;

  // The clock deadlines are measured on.
  virtual const Clock& clock() const = 0;
  // Where the requests go, for messages: "/dev/ttyUSB0 @ 38400".
  virtual std::string describe() const = 0;
  // What the line did so far (retries and exceptions are counted by the Client).
  virtual LinkStats stats() const = 0;
  // First byte sent → reply complete, of the last successful exchange.
  virtual Duration last_round_trip() const = 0;
  // The wire times of the last successful exchange; nullopt where the master
  // does not know them (then a caller dates a reply by when it got it).
  virtual std::optional<WireTimes> last_wire_times() const { return std::nullopt; }
  // The serial line's timing (baud, Ts, Td), for wire limits; behind a
  // gateway, as configured by the user.
  virtual const modbus::LineTiming& line_timing() const = 0;
  // The byte link underneath when the master speaks RTU bytes on one (`lec
  // raw` sends arbitrary bytes on it); null otherwise.
  virtual Link* link() noexcept { return nullptr; }

  // Waits until `t` on clock() without a transaction (a poll interval). The
  // default sleeps on the steady clock; a master on a virtual clock, or one
  // that should keep listening to its line meanwhile, overrides it. May
  // throw Cancelled.
  virtual void idle_until(TimePoint t);
};

}  // namespace lec6::client
