#pragma once
// What the user passes as --port, and the serial ports this machine has.
//
// Thread safety: pure functions (list_serial_ports reads /dev and /sys; it shares nothing).

#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

namespace lec6::transport {

enum class PortKind {
  Serial,      // a device path: /dev/ttyUSB0, /dev/serial/by-id/..., a twin's pty symlink
  Tcp,         // tcp://host:port — Modbus TCP (MBAP), e.g. `lec serve` or any gateway
  RtuOverTcp,  // rtu+tcp://host:port — RTU frames over TCP (device servers, `lec sim --tcp`)
  Sim,         // the in-process twin (constructed by the caller, not here)
};

inline constexpr uint16_t kDefaultTcpPort = 502;

struct PortSpec {
  PortKind kind = PortKind::Serial;
  std::string device;  // Serial: the path as given
  std::string host;    // Tcp, RtuOverTcp: host name or address, without IPv6 brackets
  uint16_t tcp_port = 0;

  // Back to the canonical text form ("/dev/ttyUSB0", "tcp://host:502",
  // "rtu+tcp://host:4001", "sim").
  std::string text() const;
  bool operator==(const PortSpec&) const = default;
};

// Parses a --port value. Accepted forms:
//   a path (absolute, or starting with ./ or ../): a serial device
//   tcp://host[:port] or tcp://[v6addr][:port], port 1..65535, default 502:
//     Modbus TCP, as users of any Modbus TCP gateway expect
//   rtu+tcp://host[:port]: Modbus RTU frames over TCP
//   sim
// Spellings of other tools (rtu://, tcp+rtu://, modbus://, host:port) get a
// hint naming the right form.
// Throws lec6::InvalidArgument with a message for the user, e.g.
//   unknown port 'foo': expected a device path like /dev/ttyUSB0, tcp://host:port, or sim
PortSpec parse_port_spec(std::string_view text);

struct SerialPortInfo {
  std::string path;         // e.g. /dev/ttyUSB0
  std::string description;  // the /dev/serial/by-id name when there is one, else the kind
  bool operator==(const SerialPortInfo&) const = default;
};

// Serial ports present: /dev/ttyUSB*, /dev/ttyACM* and /dev/ttyS* with a real
// UART behind them (sysfs /sys/class/tty/ttyS*/device exists and the port type
// is not "unknown"), described by their /dev/serial/by-id name when they have
// one. By-id links to other devices are listed too. Sorted by path. The roots
// are parameters so tests can use a fake tree.
std::vector<SerialPortInfo> list_serial_ports(const std::filesystem::path& dev_root = "/dev",
                                              const std::filesystem::path& sysfs_root = "/sys");

}  // namespace lec6::transport
