#include "lec6/transport/port_spec.hpp"
#include "lec6/error.hpp"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <fstream>
#include <map>
#include <stdexcept>
#include <system_error>
#include <tuple>

#include <fmt/format.h>

namespace lec6::transport {

namespace {

namespace fs = std::filesystem;

constexpr std::string_view kExpected =
    "expected a device path like /dev/ttyUSB0, tcp://host:port (Modbus TCP), "
    "rtu+tcp://host:port (RTU over TCP), or sim";

[[noreturn]] void bad(const std::string& message) {
  throw InvalidArgument(message);
}

uint16_t parse_tcp_port(std::string_view digits, std::string_view text) {
  unsigned value = 0;
  const auto* end = digits.data() + digits.size();
  const auto [ptr, ec] = std::from_chars(digits.data(), end, value);
  if (digits.empty() || ec != std::errc() || ptr != end || value == 0 || value > 65535) {
    bad(fmt::format("bad TCP port '{}' in '{}': expected a number from 1 to 65535", digits, text));
  }
  return static_cast<uint16_t>(value);
}

PortSpec parse_tcp(PortKind kind, std::string_view rest, std::string_view text) {
  PortSpec spec;
  spec.kind = kind;
  const std::string_view scheme = kind == PortKind::Tcp ? "tcp" : "rtu+tcp";
  spec.tcp_port = kDefaultTcpPort;
  std::string_view host;
  std::string_view after;  // what follows the host: empty or ":port"
  if (rest.starts_with('[')) {
    const auto close = rest.find(']');
    if (close == std::string_view::npos) bad(fmt::format("missing ']' in '{}'", text));
    host = rest.substr(1, close - 1);
    after = rest.substr(close + 1);
  } else {
    const auto colon = rest.find(':');
    host = rest.substr(0, colon);
    after = colon == std::string_view::npos ? std::string_view{} : rest.substr(colon);
    if (after.find(':', 1) != std::string_view::npos) {
      bad(fmt::format("cannot read '{}': write IPv6 addresses in brackets, like {}://[::1]:502",
                      text, scheme));
    }
  }
  if (host.empty()) bad(fmt::format("missing host in '{}': expected {}://host:port", text, scheme));
  if (host.find('/') != std::string_view::npos || after.find('/') != std::string_view::npos) {
    bad(fmt::format("cannot read '{}': expected {}://host:port with nothing after the port", text,
                    scheme));
  }
  if (!after.empty()) {
    if (after.front() != ':')
      bad(fmt::format("cannot read '{}': expected {}://host:port", text, scheme));
    spec.tcp_port = parse_tcp_port(after.substr(1), text);
  }
  spec.host = std::string(host);
  return spec;
}

// Sort key that puts ttyS2 before ttyS10.
std::tuple<std::string, long, std::string> natural_key(const std::string& path) {
  auto digits_start = path.size();
  while (digits_start > 0 && std::isdigit(static_cast<unsigned char>(path[digits_start - 1]))) {
    --digits_start;
  }
  if (digits_start == path.size() || path.size() - digits_start > 9) return {path, -1, path};
  return {path.substr(0, digits_start), std::stol(path.substr(digits_start)), path};
}

bool has_number_suffix(std::string_view name, std::string_view prefix) {
  if (!name.starts_with(prefix) || name.size() == prefix.size()) return false;
  return std::all_of(name.begin() + static_cast<std::ptrdiff_t>(prefix.size()), name.end(),
                     [](char c) { return c >= '0' && c <= '9'; });
}

// A ttyS node is a real UART when sysfs gives it a device and a known type
// (8250 registers placeholder ports with type 0, "unknown").
bool is_real_uart(const fs::path& sysfs_root, const std::string& name) {
  std::error_code ec;
  const fs::path dir = sysfs_root / "class" / "tty" / name;
  if (!fs::exists(dir / "device", ec)) return false;
  std::ifstream type(dir / "type");
  int value = -1;
  if (type && (type >> value) && value == 0) return false;
  return true;
}

// What other tools call their TCP transports, and what we call it.
struct OtherSpelling {
  std::string_view prefix;
  std::string_view ours;
};
constexpr OtherSpelling kOtherSpellings[] = {
    {"rtu://", "rtu+tcp://"},
    {"tcp+rtu://", "rtu+tcp://"},
    {"rtutcp://", "rtu+tcp://"},
    {"rtu-tcp://", "rtu+tcp://"},
    {"rtuovertcp://", "rtu+tcp://"},
    {"modbus://", "tcp://"},
    {"modbus+tcp://", "tcp://"},
    {"mbap://", "tcp://"},
    {"modbustcp://", "tcp://"},
    // Ours without the slashes (tcp://host:port and rtu+tcp:// were tried before).
    {"tcp:", "tcp://"},
    {"rtu+tcp:", "rtu+tcp://"},
};

[[noreturn]] void other_spelling(std::string_view text) {
  for (const auto& o : kOtherSpellings) {
    if (text.starts_with(o.prefix)) {
      bad(
          fmt::format("unknown port '{}': did you mean {}{}? (tcp:// is Modbus TCP, rtu+tcp:// is "
                      "Modbus RTU frames over TCP)",
                      text, o.ours, text.substr(o.prefix.size())));
    }
  }
  const auto colon = text.rfind(':');
  if (colon != std::string_view::npos && colon > 0 && text.find("://") == std::string_view::npos) {
    bad(
        fmt::format("unknown port '{}': a TCP address needs its protocol, tcp://{} for Modbus TCP "
                    "(e.g. lec serve) or rtu+tcp://{} for RTU frames over TCP",
                    text, text, text));
  }
  bad(fmt::format("unknown port '{}': {}", text, kExpected));
}

}  // namespace

std::string PortSpec::text() const {
  const bool v6 = host.find(':') != std::string::npos;
  switch (kind) {
    case PortKind::Serial:
      return device;
    case PortKind::Sim:
      return "sim";
    case PortKind::Tcp:
      return fmt::format(fmt::runtime(v6 ? "tcp://[{}]:{}" : "tcp://{}:{}"), host, tcp_port);
    case PortKind::RtuOverTcp:
      return fmt::format(fmt::runtime(v6 ? "rtu+tcp://[{}]:{}" : "rtu+tcp://{}:{}"), host,
                         tcp_port);
  }
  return device;
}

PortSpec parse_port_spec(std::string_view text) {
  if (text.empty()) bad(fmt::format("empty port: {}", kExpected));
  if (text == "sim") return PortSpec{PortKind::Sim, {}, {}, 0};
  if (text.starts_with("tcp://")) return parse_tcp(PortKind::Tcp, text.substr(6), text);
  if (text.starts_with("rtu+tcp://")) return parse_tcp(PortKind::RtuOverTcp, text.substr(10), text);
  if (text.starts_with('/') || text.starts_with("./") || text.starts_with("../")) {
    return PortSpec{PortKind::Serial, std::string(text), {}, 0};
  }
  if (text.starts_with("tty")) {
    bad(fmt::format("unknown port '{}': {} (did you mean /dev/{}?)", text, kExpected, text));
  }
  other_spelling(text);
}

std::vector<SerialPortInfo> list_serial_ports(const fs::path& dev_root,
                                              const fs::path& sysfs_root) {
  std::error_code ec;
  // canonical device path -> by-id name (the first, in name order)
  std::map<fs::path, std::string> by_id;
  std::vector<fs::path> links;
  for (fs::directory_iterator it(dev_root / "serial" / "by-id", ec), end; !ec && it != end;
       it.increment(ec)) {
    links.push_back(it->path());
  }
  std::sort(links.begin(), links.end());
  for (const auto& link : links) {
    const fs::path target = fs::canonical(link, ec);
    if (ec) continue;  // dangling
    by_id.emplace(target, link.filename().string());
  }

  std::map<std::string, SerialPortInfo> found;  // by path
  auto add = [&](const fs::path& path, std::string fallback) {
    std::error_code canon_ec;
    const fs::path real = fs::canonical(path, canon_ec);
    auto id = canon_ec ? by_id.end() : by_id.find(real);
    std::string description = id != by_id.end() ? id->second : std::move(fallback);
    found.emplace(path.string(), SerialPortInfo{path.string(), std::move(description)});
    if (id != by_id.end()) by_id.erase(id);
  };

  ec.clear();
  std::vector<fs::path> nodes;
  for (fs::directory_iterator it(dev_root, ec), end; !ec && it != end; it.increment(ec)) {
    nodes.push_back(it->path());
  }
  for (const auto& node : nodes) {
    const std::string name = node.filename().string();
    if (has_number_suffix(name, "ttyUSB")) {
      add(node, "USB serial adapter");
    } else if (has_number_suffix(name, "ttyACM")) {
      add(node, "USB CDC-ACM device");
    } else if (has_number_suffix(name, "ttyS") && is_real_uart(sysfs_root, name)) {
      add(node, "built-in UART");
    }
  }
  // By-id links to devices of other names (ttyXRUSB0, ...).
  for (const auto& [target, name] : by_id) {
    found.emplace(target.string(), SerialPortInfo{target.string(), name});
  }

  std::vector<SerialPortInfo> ports;
  for (auto& [path, info] : found) ports.push_back(std::move(info));
  std::sort(ports.begin(), ports.end(), [](const SerialPortInfo& a, const SerialPortInfo& b) {
    return natural_key(a.path) < natural_key(b.path);
  });
  return ports;
}

}  // namespace lec6::transport
