// SerialLink: POSIX termios, poll() with deadlines, Linux RS485 and
// low-latency ioctls. See the header for why this is our own code.

#include "lec6/transport/serial_link.hpp"
#include "lec6/error.hpp"
#include "lec6/transport/port_holder.hpp"

#include <fcntl.h>
#include <linux/serial.h>
#include <poll.h>
#include <sys/file.h>
#include <sys/ioctl.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <termios.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <fstream>
#include <stdexcept>
#include <system_error>

#include <fmt/format.h>

namespace lec6::transport {

namespace {

using client::LinkError;
using client::LinkErrorKind;

struct BaudEntry {
  uint32_t baud;
  speed_t speed;
};
constexpr BaudEntry kBauds[] = {
    {9600, B9600},   {19200, B19200},   {38400, B38400},
    {57600, B57600}, {115200, B115200}, {230400, B230400},
};

}  // namespace

speed_t termios_speed(uint32_t baud) {
  for (const auto& entry : kBauds) {
    if (entry.baud == baud) return entry.speed;
  }
  throw InvalidArgument(fmt::format(
      "unsupported baud {}: the LEC6 speaks 9600, 19200, 38400, 57600, 115200 or 230400", baud));
}

namespace {

// Time the bytes take on the wire: 10 bits per char (8N1).
Duration wire_time(std::size_t bytes, uint32_t baud) {
  return Duration(static_cast<int64_t>(static_cast<double>(bytes) * 10.0 * 1e9 / baud));
}

std::string hex(std::span<const uint8_t> bytes) {
  std::string out;
  for (std::size_t i = 0; i < bytes.size(); ++i) {
    if (i) out += ' ';
    out += fmt::format("{:02X}", bytes[i]);
  }
  return out.empty() ? std::string("(nothing)") : out;
}

// errno values that mean the device itself is gone (unplugged USB adapter,
// hung-up tty, closed pty master).
bool device_gone(int err) {
  return err == EIO || err == ENXIO || err == ENODEV || err == EPIPE;
}

}  // namespace

bool is_supported_baud(uint32_t baud) {
  return std::any_of(std::begin(kBauds), std::end(kBauds),
                     [baud](const BaudEntry& e) { return e.baud == baud; });
}

std::optional<std::string> check_latency_timer(std::string_view port,
                                               const std::filesystem::path& sysfs_root) {
  namespace fs = std::filesystem;
  const fs::path given{std::string(port)};
  std::error_code ec;
  const fs::path real = fs::canonical(given, ec);  // /dev/serial/by-id/... -> /dev/ttyUSB0
  const std::string name = (ec ? given : real).filename().string();
  if (name.empty()) return std::nullopt;
  const fs::path file = sysfs_root / "bus" / "usb-serial" / "devices" / name / "latency_timer";
  std::ifstream in(file);
  long ms = 0;
  if (!in || !(in >> ms) || ms <= 1) return std::nullopt;
  return fmt::format(
      "{} is {} ms: the USB adapter holds received bytes for up to {} ms before passing them on, "
      "which delays every reply; set it to 1 ms with: echo 1 > {} (as root, e.g. "
      "echo 1 | sudo tee {}; a udev rule makes it permanent)",
      file.string(), ms, ms, file.string(), file.string());
}

SerialLink::SerialLink(std::string path, SerialOptions options)
    : path_(std::move(path)), options_(std::move(options)) {
  termios_speed(options_.baud);  // refuse an unsupported baud before touching the device

  const int fd = ::open(path_.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) {
    const int err = errno;
    if (err == EBUSY) {
      throw LinkError(LinkErrorKind::PortUnavailable, port_busy_message(path_));
    }
    if (err == EACCES) {
      throw LinkError(LinkErrorKind::PortUnavailable,
                      fmt::format("cannot open {}: {} (is your user in the group that owns it, "
                                  "usually 'dialout'?)",
                                  path_, errno_text(err)));
    }
    throw LinkError(LinkErrorKind::PortUnavailable,
                    fmt::format("cannot open {}: {}", path_, errno_text(err)));
  }
  fd_.reset(fd);
  if (!::isatty(fd)) {
    throw LinkError(LinkErrorKind::PortUnavailable,
                    fmt::format("cannot open {}: not a serial device", path_));
  }
  // Unix98 pty slaves have the character-device majors 136-143 (UNIX98_PTY_SLAVE_MAJOR).
  struct stat st {};
  pty_ = ::fstat(fd, &st) == 0 && S_ISCHR(st.st_mode) && major(st.st_rdev) >= 136 &&
         major(st.st_rdev) <= 143;
  if (options_.exclusive) {
    // flock holds against every cooperating program, root included; TIOCEXCL
    // makes the kernel refuse other opens (except by root).
    if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
      const int err = errno;
      if (err == EWOULDBLOCK) {
        fd_.reset();  // not ours: do not name ourselves as a holder
        throw LinkError(LinkErrorKind::PortUnavailable, port_busy_message(path_));
      }
      // Some file systems do not support locks; TIOCEXCL still applies.
    }
    if (::ioctl(fd, TIOCEXCL) == 0) exclusive_set_ = true;
  }
  try {
    configure();
  } catch (...) {
    // No destructor runs for a half-built object: release the port here.
    if (exclusive_set_) ::ioctl(fd, TIOCNXCL);
    throw;
  }
  if (auto warning = check_latency_timer(path_, options_.sysfs_root)) {
    warnings_.push_back(std::move(*warning));
  }
}

SerialLink::~SerialLink() {
  // The exclusive flag lives on the tty, not on our descriptor: on a pty whose
  // slave is held open by the twin it would outlive us and lock out the next
  // client, so clear it explicitly. (The flock goes away with the descriptor.)
  if (fd_ && exclusive_set_) ::ioctl(fd_.get(), TIOCNXCL);
}

void SerialLink::configure() {
  const int fd = fd_.get();
  const speed_t speed = termios_speed(options_.baud);
  auto refuse = [this](const std::string& what, int err) {
    throw LinkError(LinkErrorKind::PortUnavailable,
                    fmt::format("cannot configure {}: {}: {}", path_, what, errno_text(err)));
  };

  termios tio{};
  if (::tcgetattr(fd, &tio) != 0) refuse("tcgetattr", errno);
  ::cfmakeraw(&tio);
  tio.c_cflag &= ~static_cast<tcflag_t>(CSIZE | PARENB | CSTOPB | CRTSCTS);
  tio.c_cflag |= CS8 | CLOCAL | CREAD;
  tio.c_iflag &= ~static_cast<tcflag_t>(IXON | IXOFF | IXANY | INPCK | ISTRIP);
  tio.c_iflag |= IGNBRK;
  // VMIN=1: with O_NONBLOCK a read with nothing there gives EAGAIN, so a read
  // of 0 bytes can only mean hang-up.
  tio.c_cc[VMIN] = 1;
  tio.c_cc[VTIME] = 0;
  if (::cfsetispeed(&tio, speed) != 0 || ::cfsetospeed(&tio, speed) != 0) {
    refuse(fmt::format("cannot set {} baud", options_.baud), errno);
  }
  if (::tcsetattr(fd, TCSANOW, &tio) != 0) refuse("tcsetattr", errno);
  termios check{};
  if (::tcgetattr(fd, &check) != 0) refuse("tcgetattr", errno);
  if (::cfgetospeed(&check) != speed || ::cfgetispeed(&check) != speed) {
    throw LinkError(
        LinkErrorKind::PortUnavailable,
        fmt::format("cannot configure {}: the driver refused {} baud", path_, options_.baud));
  }

  if (options_.rs485.enabled) {
    serial_rs485 rs{};
    rs.flags = SER_RS485_ENABLED;
    if (options_.rs485.rts_on_send) rs.flags |= SER_RS485_RTS_ON_SEND;
    if (options_.rs485.rts_after_send) rs.flags |= SER_RS485_RTS_AFTER_SEND;
    rs.delay_rts_before_send = options_.rs485.delay_before_send_ms;
    rs.delay_rts_after_send = options_.rs485.delay_after_send_ms;
    if (::ioctl(fd, TIOCSRS485, &rs) != 0) {
      const int err = errno;
      throw LinkError(
          LinkErrorKind::PortUnavailable,
          fmt::format("{}: the driver refused kernel RS485 mode (ioctl TIOCSRS485: {}); "
                      "use an adapter with automatic direction control and turn "
                      "RS485 mode off",
                      path_, errno_text(err)));
    }
    serial_rs485 got{};
    if (::ioctl(fd, TIOCGRS485, &got) != 0 || !(got.flags & SER_RS485_ENABLED)) {
      throw LinkError(LinkErrorKind::PortUnavailable,
                      fmt::format("{}: the driver accepted ioctl TIOCSRS485 but did not enable "
                                  "RS485 mode; use an adapter with automatic direction control",
                                  path_));
    }
  }

  if (options_.low_latency) {
    // ASYNC_LOW_LATENCY: on 8250 UARTs it hands received bytes over at once;
    // ftdi_sio maps it to a 1 ms latency_timer. Drivers without TIOCGSERIAL
    // (ptys, cdc-acm on some kernels) answer ENOTTY/EINVAL: nothing to do.
    serial_struct ss{};
    int r = ::ioctl(fd, TIOCGSERIAL, &ss);
    if (r == 0 && !(ss.flags & ASYNC_LOW_LATENCY)) {
      ss.flags |= ASYNC_LOW_LATENCY;
      r = ::ioctl(fd, TIOCSSERIAL, &ss);
    }
    if (r != 0 && errno != ENOTTY && errno != EINVAL) {
      warnings_.push_back(fmt::format("{}: could not set low-latency mode (TIOCSSERIAL: {})", path_,
                                      errno_text(errno)));
    }
  }

  if (::tcflush(fd, TCIOFLUSH) != 0) refuse("tcflush", errno);
}

void SerialLink::fail(const char* operation, int err) const {
  if (device_gone(err)) {
    throw LinkError(LinkErrorKind::PortLost, fmt::format("the serial port {} went away ({}: {})",
                                                         path_, operation, errno_text(err)));
  }
  throw LinkError(LinkErrorKind::Io,
                  fmt::format("{}: {} failed: {}", path_, operation, errno_text(err)));
}

void SerialLink::write(std::span<const uint8_t> bytes) {
  const int fd = fd_.get();
  // Without flow control a UART always drains; the bound only matters for a
  // pty whose other side stopped reading.
  const TimePoint deadline =
      clock_.now() + 2 * wire_time(bytes.size(), options_.baud) + std::chrono::seconds(1);
  std::size_t done = 0;
  try {
    done = write_all(fd, bytes, deadline, clock_,
                     [fd](const uint8_t* p, std::size_t n) { return ::write(fd, p, n); });
  } catch (const SystemError& e) {
    fail("write", e.code().value());
  }
  if (done < bytes.size()) {
    throw LinkError(LinkErrorKind::Io, fmt::format("{}: write timed out ({} of {} bytes sent)",
                                                   path_, done, bytes.size()));
  }
  // The query's timing starts when its last byte has left the transmitter; a
  // pty has none, and the call would be one more system call per query.
  while (!pty_ && ::tcdrain(fd) != 0) {
    if (errno != EINTR) fail("tcdrain", errno);
  }
  if (options_.discard_echo) swallow_echo(bytes);
}

void SerialLink::swallow_echo(std::span<const uint8_t> sent) {
  std::vector<uint8_t> echo(sent.size());
  const Duration allowed = wire_time(sent.size(), options_.baud) + options_.echo_timeout;
  const std::size_t got = client::read_until_full(*this, echo, clock_.now() + allowed);
  const std::span<const uint8_t> echoed(echo.data(), got);
  const bool prefix_matches = std::equal(echoed.begin(), echoed.end(), sent.begin());
  if (got == sent.size() && prefix_matches) return;
  if (!prefix_matches) {
    throw LinkError(
        LinkErrorKind::EchoMismatch,
        fmt::format("bus collision on {}: sent {} echoed {}", path_, hex(sent), hex(echoed)));
  }
  throw LinkError(LinkErrorKind::EchoMismatch,
                  fmt::format("incomplete local echo on {}: sent {} echoed {} (only {} of {} bytes "
                              "came back within {:.1f} ms): a bus collision, or an adapter that "
                              "does not echo what it sends (then turn echo discard off)",
                              path_, hex(sent), hex(echoed), got, sent.size(), to_ms(allowed)));
}

std::size_t SerialLink::read_some(std::span<uint8_t> buffer, TimePoint deadline) {
  const int fd = fd_.get();
  ReadSome got;
  try {
    got = read_until(fd, buffer, deadline, clock_,
                     [fd](uint8_t* p, std::size_t n) { return ::read(fd, p, n); });
  } catch (const SystemError& e) {
    fail(e.call().c_str(), e.code().value());
  }
  // VMIN=1 and O_NONBLOCK: 0 bytes is end of file, i.e. a hung-up tty.
  if (got.closed) {
    throw LinkError(LinkErrorKind::PortLost,
                    fmt::format("the serial port {} went away (hung up)", path_));
  }
  return got.bytes;
}

std::size_t SerialLink::read_some_exact(std::span<uint8_t> buffer, TimePoint deadline) {
  const TimePoint wake = deadline - options_.spin_before_deadline;
  if (clock_.now() < wake) {
    if (const std::size_t n = read_some(buffer, wake); n > 0) return n;
  }
  // The last stretch: a zero-timeout poll per turn (read_some with a
  // deadline already past checks the descriptor once), until the deadline.
  for (;;) {
    const bool last = clock_.now() >= deadline;
    if (const std::size_t n = read_some(buffer, TimePoint{}); n > 0 || last) return n;
  }
}

void SerialLink::discard_input() {
  if (::tcflush(fd_.get(), TCIFLUSH) != 0) fail("tcflush", errno);
}

std::string SerialLink::describe() const {
  return fmt::format("{} @ {}", path_, options_.baud);
}

}  // namespace lec6::transport
