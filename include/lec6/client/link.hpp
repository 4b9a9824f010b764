#pragma once
// The byte pipe a Client talks through. One small vtable, in the spirit of
// libmodbus's backends: the transports (serial, TCP, in-process twin) live in
// transport/ and implement it; the client never knows which one it has.
//
// Thread safety: a Link is used by one thread at a time (its Client's); LinkError as in error.hpp.

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>

#include "lec6/clock.hpp"
#include "lec6/error.hpp"

namespace lec6::client {

// Why a link failed, in the user's terms. Transport errors are never
// controller exceptions: they say nothing about what the controller did.
enum class LinkErrorKind {
  PortUnavailable,  // cannot open: missing, busy, permission
  PortLost,         // the device vanished mid-run (unplugged adapter, closed pty)
  EchoMismatch,     // 2-wire local echo differs from what was sent: bus collision
  Io,               // any other operating-system error
};

class LinkError : public Error {
 public:
  LinkError(LinkErrorKind kind, const std::string& what) : Error(what), kind_(kind) {}
  LinkErrorKind kind() const noexcept { return kind_; }

 private:
  LinkErrorKind kind_;
};

class Link {
 public:
  virtual ~Link() = default;

  // Sends the bytes and returns once they have left (serial: tcdrain), so the
  // caller's clock reads the end of the query. Throws LinkError.
  virtual void write(std::span<const uint8_t> bytes) = 0;

  // Waits until at least one byte is available or `deadline` passes (as read
  // on clock()), then returns what is there without waiting for more.
  // Returns 0 on timeout. Throws LinkError.
  virtual std::size_t read_some(std::span<uint8_t> buffer, TimePoint deadline) = 0;

  // read_some for a deadline that is an instant to keep, not a bound (the
  // end of the silent interval before a query): a link whose timers wake
  // late may sleep until shortly before it and poll the rest without
  // sleeping. Same contract as read_some otherwise.
  virtual std::size_t read_some_exact(std::span<uint8_t> buffer, TimePoint deadline) {
    return read_some(buffer, deadline);
  }

  // Drops whatever input is buffered (stale bytes from an earlier transaction).
  virtual void discard_input() = 0;

  // The clock deadlines are measured on. Real links use the steady clock; the
  // in-process twin may run on a virtual one so that waiting costs nothing.
  virtual const Clock& clock() const = 0;

  // The line speed, for timing (Ts, wire time). TCP links report the speed of
  // the serial line behind them, as configured.
  virtual uint32_t baud() const = 0;

  // What the user typed to get this link, e.g. "/dev/ttyUSB0 @ 38400".
  virtual std::string describe() const = 0;
};

// Reads until `buffer` is full or `deadline` passes (read_some until it
// returns 0); returns how many bytes came. A 2-wire adapter's echo is read
// back so (transport::SerialLink, twin::VirtualLine).
inline std::size_t read_until_full(Link& link, std::span<uint8_t> buffer, TimePoint deadline) {
  std::size_t got = 0;
  while (got < buffer.size()) {
    const std::size_t n = link.read_some(buffer.subspan(got), deadline);
    if (n == 0) break;
    got += n;
  }
  return got;
}

}  // namespace lec6::client
