#pragma once
// A Link over a local serial port (USB-RS485 adapter, on-board UART, or the
// slave side of a pseudo-terminal) using POSIX termios directly.
//
// Why our own code and not a portable serial library: we need the Linux RS485
// ioctls (TIOCSRS485: kernel-driven transmit enable), exact timing (write
// returns only after tcdrain, reads wait with poll() on a deadline, no hidden
// read timeouts; only read_some_exact polls, for its last
// spin_before_deadline), local-echo control for 2-wire adapters, and
// the low-latency / USB latency_timer knobs. Portable libraries hide or lack
// all of these.
//
// Thread safety: one thread at a time.

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <termios.h>

#include "lec6/client/link.hpp"
#include "lec6/clock.hpp"
#include "lec6/transport/fd.hpp"

namespace lec6::transport {

// The termios speed of a LEC6 baud rate (B9600 … B230400): one table for the
// serial link, the twin's pty and lec sniff. Another rate: InvalidArgument
// naming the six the controller speaks.
speed_t termios_speed(uint32_t baud);

// Kernel RS485 mode (TIOCSRS485): the UART driver switches the transceiver's
// driver-enable line (RTS) around each transmission. Only for UARTs whose
// driver supports it (many on-board SoC UARTs); USB adapters with automatic
// direction control need none of this.
struct Rs485Options {
  bool enabled = false;
  bool rts_on_send = true;      // RTS level while sending (true: logical 1)
  bool rts_after_send = false;  // RTS level after sending
  uint32_t delay_before_send_ms = 0;
  uint32_t delay_after_send_ms = 0;
};

struct SerialOptions {
  // Line speed: 9600, 19200, 38400, 57600, 115200 or 230400 (8N1, no flow control).
  uint32_t baud = 38400;
  Rs485Options rs485{};
  // 2-wire adapters without echo suppression receive what they send. With
  // this on, write() reads back exactly the bytes sent and compares them; a
  // difference is a bus collision (LinkError EchoMismatch).
  bool discard_echo = false;
  // How long, beyond the bytes' own wire time, write() waits for the echo.
  Duration echo_timeout = std::chrono::milliseconds(50);
  // Set ASYNC_LOW_LATENCY where the driver supports it (silently skipped where not).
  bool low_latency = true;
  // Refuse other openers while we hold the port (TIOCEXCL plus an flock, which
  // also holds against root). Released on close.
  bool exclusive = true;
  // Timer wake-ups come tens of microseconds late (hundreds on a busy VM,
  // even with 1 ns timer slack). read_some_exact() sleeps until this much
  // before its deadline and polls the descriptor without sleeping for the
  // rest, so the wait for Ts before a query ends at its instant. Zero:
  // sleep only. Costs at most this much CPU per query.
  Duration spin_before_deadline = std::chrono::microseconds(200);
  // Root of sysfs, for the USB latency_timer check (tests point it elsewhere).
  std::filesystem::path sysfs_root = "/sys";
};

// True for the speeds the controller supports.
bool is_supported_baud(uint32_t baud);

// If `port` (a device path, symlinks allowed) is a USB serial adapter whose
// latency_timer is above 1 ms, returns a warning naming the sysfs file and the
// fix. Returns nullopt for other devices, unreadable files, or a good value.
std::optional<std::string> check_latency_timer(std::string_view port,
                                               const std::filesystem::path& sysfs_root = "/sys");

class SerialLink final : public client::Link {
 public:
  // Opens and configures the port. Throws lec6::InvalidArgument for an
  // unsupported baud, LinkError PortUnavailable when the port cannot be opened
  // or configured as asked (message names the port).
  explicit SerialLink(std::string path, SerialOptions options = {});
  ~SerialLink() override;
  SerialLink(const SerialLink&) = delete;
  SerialLink& operator=(const SerialLink&) = delete;

  void write(std::span<const uint8_t> bytes) override;
  std::size_t read_some(std::span<uint8_t> buffer, TimePoint deadline) override;
  std::size_t read_some_exact(std::span<uint8_t> buffer, TimePoint deadline) override;
  void discard_input() override;
  const Clock& clock() const override { return clock_; }
  uint32_t baud() const override { return options_.baud; }
  std::string describe() const override;

  const std::string& path() const { return path_; }
  const SerialOptions& options() const { return options_; }
  // The open descriptor (non-blocking), for callers that poll it.
  int fd() const { return fd_.get(); }
  // Things the user should know but that did not stop the port from opening
  // (e.g. a USB latency_timer above 1 ms).
  const std::vector<std::string>& warnings() const { return warnings_; }

 private:
  void configure();
  void swallow_echo(std::span<const uint8_t> sent);
  [[noreturn]] void fail(const char* operation, int err) const;

  std::string path_;
  SerialOptions options_;
  SteadyClock clock_;
  UniqueFd fd_;
  bool exclusive_set_ = false;
  // The slave side of a pseudo-terminal (the twin's): no transmitter, so
  // write() does not wait for one to drain (tcdrain has nothing to wait for).
  bool pty_ = false;
  std::vector<std::string> warnings_;
};

}  // namespace lec6::transport
