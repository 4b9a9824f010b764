#include <stdexcept>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "lec6/error.hpp"
#include "lec6/transport/port_spec.hpp"

namespace lec6::transport {
namespace {

struct Good {
  std::string text;
  PortSpec spec;
  std::string canonical;
};

class ParsePortSpec : public ::testing::TestWithParam<Good> {};

TEST_P(ParsePortSpec, Parses) {
  const Good& good = GetParam();
  const PortSpec spec = parse_port_spec(good.text);
  EXPECT_EQ(spec, good.spec);
  EXPECT_EQ(spec.text(), good.canonical);
}

INSTANTIATE_TEST_SUITE_P(
    Table, ParsePortSpec,
    ::testing::Values(
        Good{"/dev/ttyUSB0", {PortKind::Serial, "/dev/ttyUSB0", "", 0}, "/dev/ttyUSB0"},
        Good{"/dev/serial/by-id/usb-FTDI_FT232R-if00-port0",
             {PortKind::Serial, "/dev/serial/by-id/usb-FTDI_FT232R-if00-port0", "", 0},
             "/dev/serial/by-id/usb-FTDI_FT232R-if00-port0"},
        Good{"/tmp/lec-sim", {PortKind::Serial, "/tmp/lec-sim", "", 0}, "/tmp/lec-sim"},
        Good{"./ttyV0", {PortKind::Serial, "./ttyV0", "", 0}, "./ttyV0"},
        Good{"../ttyV0", {PortKind::Serial, "../ttyV0", "", 0}, "../ttyV0"},
        Good{"tcp://192.168.1.50:4001",
             {PortKind::Tcp, "", "192.168.1.50", 4001},
             "tcp://192.168.1.50:4001"},
        Good{"tcp://moxa.local", {PortKind::Tcp, "", "moxa.local", 502}, "tcp://moxa.local:502"},
        Good{"tcp://localhost:65535",
             {PortKind::Tcp, "", "localhost", 65535},
             "tcp://localhost:65535"},
        Good{"tcp://[::1]:5020", {PortKind::Tcp, "", "::1", 5020}, "tcp://[::1]:5020"},
        Good{"tcp://[fe80::1]", {PortKind::Tcp, "", "fe80::1", 502}, "tcp://[fe80::1]:502"},
        Good{"rtu+tcp://10.0.0.5:4001",
             {PortKind::RtuOverTcp, "", "10.0.0.5", 4001},
             "rtu+tcp://10.0.0.5:4001"},
        Good{"rtu+tcp://[::1]", {PortKind::RtuOverTcp, "", "::1", 502}, "rtu+tcp://[::1]:502"},
        Good{"sim", {PortKind::Sim, "", "", 0}, "sim"}));

class RejectPortSpec : public ::testing::TestWithParam<std::pair<std::string, std::string>> {};

TEST_P(RejectPortSpec, WithAMessage) {
  const auto& [text, message] = GetParam();
  try {
    parse_port_spec(text);
    FAIL() << "accepted '" << text << "'";
  } catch (const lec6::InvalidArgument& e) {
    EXPECT_EQ(std::string(e.what()), message);
  }
}

INSTANTIATE_TEST_SUITE_P(
    Table, RejectPortSpec,
    ::testing::Values(
        std::pair{std::string("foo"),
                  std::string(
                      "unknown port 'foo': expected a device path like /dev/ttyUSB0, "
                      "tcp://host:port (Modbus TCP), rtu+tcp://host:port (RTU over TCP), or sim")},
        std::pair{std::string(""),
                  std::string(
                      "empty port: expected a device path like /dev/ttyUSB0, "
                      "tcp://host:port (Modbus TCP), rtu+tcp://host:port (RTU over TCP), or sim")},
        std::pair{
            std::string("ttyUSB0"),
            std::string("unknown port 'ttyUSB0': expected a device path like "
                        "/dev/ttyUSB0, tcp://host:port (Modbus TCP), rtu+tcp://host:port (RTU "
                        "over TCP), or sim (did you mean /dev/ttyUSB0?)")},
        std::pair{std::string("SIM"),
                  std::string(
                      "unknown port 'SIM': expected a device path like /dev/ttyUSB0, "
                      "tcp://host:port (Modbus TCP), rtu+tcp://host:port (RTU over TCP), or sim")},
        std::pair{std::string("udp://host:502"),
                  std::string("unknown port 'udp://host:502': expected a device path like "
                              "/dev/ttyUSB0, tcp://host:port (Modbus TCP), rtu+tcp://host:port "
                              "(RTU over TCP), or sim")},
        // Other tools' spellings get the right form.
        std::pair{std::string("rtu://10.0.0.5:4001"),
                  std::string("unknown port 'rtu://10.0.0.5:4001': did you mean "
                              "rtu+tcp://10.0.0.5:4001? (tcp:// is Modbus TCP, rtu+tcp:// is "
                              "Modbus RTU frames over TCP)")},
        std::pair{std::string("modbus://plc:502"),
                  std::string("unknown port 'modbus://plc:502': did you mean tcp://plc:502? "
                              "(tcp:// is Modbus TCP, rtu+tcp:// is Modbus RTU frames over TCP)")},
        std::pair{std::string("tcp:127.0.0.1:1502"),
                  std::string("unknown port 'tcp:127.0.0.1:1502': did you mean "
                              "tcp://127.0.0.1:1502? (tcp:// is Modbus TCP, rtu+tcp:// is Modbus "
                              "RTU frames over TCP)")},
        std::pair{std::string("rtu+tcp:gw:4001"),
                  std::string("unknown port 'rtu+tcp:gw:4001': did you mean rtu+tcp://gw:4001? "
                              "(tcp:// is Modbus TCP, rtu+tcp:// is Modbus RTU frames over TCP)")},
        std::pair{std::string("127.0.0.1:1502"),
                  std::string("unknown port '127.0.0.1:1502': a TCP address needs its protocol, "
                              "tcp://127.0.0.1:1502 for Modbus TCP (e.g. lec serve) or "
                              "rtu+tcp://127.0.0.1:1502 for RTU frames over TCP")},
        std::pair{std::string("rtu+tcp://:4001"),
                  std::string("missing host in 'rtu+tcp://:4001': expected rtu+tcp://host:port")},
        std::pair{std::string("tcp://"),
                  std::string("missing host in 'tcp://': expected tcp://host:port")},
        std::pair{std::string("tcp://:502"),
                  std::string("missing host in 'tcp://:502': expected tcp://host:port")},
        std::pair{std::string("tcp://host:"),
                  std::string("bad TCP port '' in 'tcp://host:': expected a number from 1 to "
                              "65535")},
        std::pair{std::string("tcp://host:0"),
                  std::string("bad TCP port '0' in 'tcp://host:0': expected a number from 1 "
                              "to 65535")},
        std::pair{std::string("tcp://host:65536"),
                  std::string("bad TCP port '65536' in 'tcp://host:65536': expected a number "
                              "from 1 to 65535")},
        std::pair{std::string("tcp://host:50x"),
                  std::string("bad TCP port '50x' in 'tcp://host:50x': expected a number from "
                              "1 to 65535")},
        std::pair{std::string("tcp://host:502/path"),
                  std::string("cannot read 'tcp://host:502/path': expected tcp://host:port "
                              "with nothing after the port")},
        std::pair{std::string("tcp://::1:502"),
                  std::string("cannot read 'tcp://::1:502': write IPv6 addresses in brackets, "
                              "like tcp://[::1]:502")},
        std::pair{std::string("tcp://[::1"), std::string("missing ']' in 'tcp://[::1'")},
        std::pair{std::string("tcp://[::1]x"),
                  std::string("cannot read 'tcp://[::1]x': expected tcp://host:port")}));

}  // namespace
}  // namespace lec6::transport
