// twin::open_port: each kind of port spec gives a Master that reaches the
// controller; a port that cannot be opened says which and why.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <thread>

#include "lec6/client/client.hpp"
#include "lec6/transport/serial_link.hpp"
#include "lec6/twin/open_port.hpp"
#include "lec6/twin/sim_server.hpp"
#include "twin/served_twin.hpp"

namespace lec6::twin {
namespace {

using ::testing::HasSubstr;
using transport::parse_port_spec;

// A pty twin on its own thread for the test's duration.
struct PortTwin : testing::ServedTwin {
  explicit PortTwin(sim::Timing timing)
      : testing::ServedTwin({1}, testing::pty_only(), sim::LineConfig{{}, timing}) {}
};

TEST(OpenPort, SimIsATwinInThisProcessWithTheGivenId) {
  PortOptions o;
  o.sim_id = 7;
  auto port = open_port(parse_port_spec("sim"), o);
  ASSERT_NE(port->twin(), nullptr);
  EXPECT_EQ(port->twin()->ids(), std::vector<uint8_t>{7});
  EXPECT_EQ(port->description(), "in-process twin");
  client::Client c(port->master(), {.id = 7});
  EXPECT_FALSE(c.read_flags().svre());
  EXPECT_EQ(port->master().line_timing().baud, 38400u);
}

// `--port sim` is the default twin of `lec sim` (the field's evidence: BUSY
// rises late), unless the options name another (`lec --sim-profile ideal`).
TEST(OpenPort, SimIsTheDefaultTwinUnlessToldOtherwise) {
  auto port = open_port(parse_port_spec("sim"), {});
  const auto& defaults = port->twin()->find(1)->config();
  EXPECT_EQ(defaults.busy_delay, sim::default_config().busy_delay);
  EXPECT_GT(defaults.busy_delay, Duration::zero());
  EXPECT_EQ(defaults.origin_speed_mm_s, sim::default_config().origin_speed_mm_s);
  PortOptions o;
  o.sim_actuator = sim::ideal_config();
  auto ideal = open_port(parse_port_spec("sim"), o);
  EXPECT_EQ(ideal->twin()->find(1)->config().busy_delay, Duration::zero());
}

TEST(OpenPort, SerialDeviceSpeaksRtuWithTheGivenLineSettings) {
  PortTwin twin(sim::Timing::Fast);
  PortOptions o;
  o.baud = 115200;
  o.wait_for_silence = false;
  const std::string path = twin.server().pty()->client_path();
  auto port = open_port(parse_port_spec(path), o);
  EXPECT_EQ(port->twin(), nullptr);
  EXPECT_THAT(port->description(), HasSubstr(path));
  EXPECT_EQ(port->master().line_timing().baud, 115200u);
  ASSERT_NE(port->master().link(), nullptr);  // `lec raw` needs the byte link
  client::Client c(port->master(), {.id = 1});
  EXPECT_EQ(c.read_name().text, "LEC6-TWIN");
}

TEST(OpenPort, MissingDeviceNamesIt) {
  const std::string path = (std::filesystem::temp_directory_path() / "lec6-no-such-tty").string();
  try {
    open_port(parse_port_spec(path), {});
    FAIL() << "opened a port that does not exist";
  } catch (const client::LinkError& e) {
    EXPECT_EQ(e.kind(), client::LinkErrorKind::PortUnavailable);
    EXPECT_THAT(e.what(), HasSubstr(path));
  }
}

TEST(OpenPort, ModbusTcpWithNobodyListeningIsATransportError) {
  // Port 1 on loopback: nothing listens there without root.
  try {
    open_port(parse_port_spec("tcp://127.0.0.1:1"), {});
    FAIL() << "connected to nobody";
  } catch (const client::TransportError& e) {
    EXPECT_EQ(e.kind(), client::TransportErrorKind::Port);
    EXPECT_THAT(e.what(), HasSubstr("tcp://127.0.0.1:1"));
  }
}

}  // namespace
}  // namespace lec6::twin
