#pragma once
// A Link carrying bytes over TCP: RTU frames (with CRC, no MBAP header) to
// serial device servers in transparent mode and `lec sim --tcp`
// (`rtu+tcp://host:port`), and the stream under a Modbus TCP master.
//
// Thread safety: one thread at a time.

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>

#include "lec6/client/link.hpp"
#include "lec6/clock.hpp"
#include "lec6/transport/fd.hpp"

namespace lec6::transport {

struct TcpOptions {
  // Speed of the serial line behind the device server; used only for timing
  // (Ts, wire time), never sent anywhere.
  uint32_t baud = 38400;
  Duration connect_timeout = std::chrono::seconds(3);
  // How the link names itself in messages: "rtu+tcp" for RTU frames over TCP,
  // "tcp" for a plain byte stream (e.g. under a Modbus TCP master).
  std::string scheme = "tcp";
};

class TcpLink final : public client::Link {
 public:
  // Resolves `host` and connects (TCP_NODELAY) within options.connect_timeout.
  // Throws LinkError PortUnavailable naming tcp://host:port on failure
  // (refused, unreachable, timed out, unknown host). Name resolution itself
  // uses getaddrinfo and is not bounded by the timeout.
  TcpLink(std::string host, uint16_t port, TcpOptions options = {});
  TcpLink(const TcpLink&) = delete;
  TcpLink& operator=(const TcpLink&) = delete;

  // Returns once the kernel has taken all bytes (TCP cannot tell when they
  // leave the device server's UART). A closed connection: PortLost.
  void write(std::span<const uint8_t> bytes) override;
  std::size_t read_some(std::span<uint8_t> buffer, TimePoint deadline) override;
  // Drops whatever the socket has received so far.
  void discard_input() override;
  const Clock& clock() const override { return clock_; }
  uint32_t baud() const override { return options_.baud; }
  // "rtu+tcp://host:port @ 38400" (scheme from the options)
  std::string describe() const override;

  const std::string& host() const { return host_; }
  uint16_t port() const { return port_; }
  int fd() const { return fd_.get(); }

  // "rtu+tcp://host:port", without the baud.
  std::string url() const;

 private:
  [[noreturn]] void fail(const char* operation, int err) const;

  std::string host_;
  uint16_t port_;
  TcpOptions options_;
  SteadyClock clock_;
  UniqueFd fd_;
};

}  // namespace lec6::transport
