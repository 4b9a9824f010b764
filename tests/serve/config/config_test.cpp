// The serve config: a full example parses; every mistake names file, line,
// key and rule; flags make the simple case.

#include "lec6/serve/config.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace lec6::serve {
namespace {

using ::testing::HasSubstr;

std::string error_of(const std::string& text) {
  try {
    parse_config(text, "lec6.yaml");
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(ServeConfig, AFullFileParses) {
  const auto c = parse_config(R"(
lines:
  - name: press
    port: sim
    baud: 115200
    silent_interval: 2
    delay_ms: 3
    poll_max_wait_ms: 250
    sim: {timing: fast, workpiece_mm: 350}
    axes:
      - {id: 1, name: x, telemetry_hz: 20}
      - {id: 2, name: y}
    modbus_tcp: {listen: "127.0.0.1:15020", read_only: true}
    rtu_tcp: {listen: ":15030"}
http: {listen: "127.0.0.1:18080"}
mqtt: {broker: "mqtt://127.0.0.1:1883", prefix: plant}
)",
                              "lec6.yaml");
  ASSERT_EQ(c.lines.size(), 1u);
  const auto& l = c.lines[0];
  EXPECT_EQ(l.name, "press");
  EXPECT_EQ(l.baud, 115200u);
  EXPECT_EQ(l.poll_max_wait_ms, 250);
  EXPECT_TRUE(l.sim.fast);
  EXPECT_EQ(l.sim.workpiece_mm, 350.0);
  ASSERT_EQ(l.axes.size(), 2u);
  EXPECT_EQ(l.axes[1].name, "y");
  EXPECT_EQ(l.axes[1].telemetry_hz, 10);
  EXPECT_TRUE(l.modbus_tcp->read_only);
  EXPECT_EQ(l.rtu_tcp->listen.text(), "127.0.0.1:15030");
  EXPECT_EQ(c.http->listener.listen.port, 18080);
  EXPECT_EQ(c.mqtt->prefix, "plant");
  EXPECT_EQ(c.find_axis("y")->axis->id, 2);
  // Twice the slowest telemetry period (10 Hz).
  EXPECT_EQ(l.cache_max_age(), std::chrono::milliseconds(200));
}

TEST(ServeConfig, MistakesNameTheFileTheLineAndTheRule) {
  EXPECT_EQ(error_of("lines:\n  - port: sim\n    axes:\n      - {id: 300}\n"),
            "lec6.yaml:4: lines[0].axes[0].id: 300 is not a controller ID (1 to 255, digest §2)");
  EXPECT_EQ(error_of("lines:\n  - port: sim\n    baudrate: 9600\n    axes: [{id: 1}]\n"),
            "lec6.yaml:3: lines[0].baudrate: unknown key: did you mean 'baud'?");
  EXPECT_THAT(error_of("lines:\n  - port: sim\n    baud: 1200\n    axes: [{id: 1}]\n"),
              HasSubstr("1200 is not a baud rate the controller has"));
  EXPECT_THAT(error_of("lines:\n  - port: sim\n    axes: [{id: 1}, {id: 1}]\n"),
              HasSubstr("ID 1 is already an axis of this line"));
  EXPECT_THAT(error_of("lines:\n  - port: tcp://plc:502\n    axes: [{id: 1}]\n"),
              HasSubstr("is Modbus TCP: a line is driven in Modbus RTU"));
  EXPECT_THAT(error_of("lines:\n  - port: sim\n    axes: [{id: 1, name: 'a b'}]\n"),
              HasSubstr("names are 1 to 64 letters"));
  EXPECT_THAT(error_of("lines:\n  - port: sim\n    axes: [{id: 1, name: x}]\n"
                       "  - port: sim\n    axes: [{id: 2, name: x}]\n"),
              HasSubstr("an axis called 'x' already exists"));
  EXPECT_THAT(error_of("lines: [\n"), HasSubstr("lec6.yaml:"));
  EXPECT_THAT(error_of("lines:\n  - port: sim\n    axes: []\n"),
              HasSubstr("a line needs a list of axes"));
  EXPECT_THAT(error_of("lines:\n  - port: sim\n    axes: [{id: 1}]\n"
                       "http: {listen: '0.0.0.0:8080'}\n"),
              HasSubstr("reachable from other machines: set http.token"));
  EXPECT_THAT(error_of("lines:\n  - port: sim\n    axes: [{id: 1}]\n    delay_ms: fast\n"),
              HasSubstr("lines[0].delay_ms: 'fast' is not a number"));
  EXPECT_THAT(error_of("lines:\n  - port: sim\n    axes: [{id: 1}]\n    poll_max_wait_ms: -1\n"),
              HasSubstr("lec6.yaml:4: lines[0].poll_max_wait_ms: -1 is outside 0 to 60000"));
}

// alarm_polarity (issue 33): a line's for all its axes, an axis's over it;
// a bad value names the key and the two values it may take.
TEST(ServeConfig, AlarmPolarityPerLineAndPerAxis) {
  const auto c = parse_config(
      "lines:\n  - port: sim\n    alarm_polarity: active-low\n"
      "    axes: [{id: 1}, {id: 2, alarm_polarity: active-high}]\n"
      "  - port: sim\n    axes: [{id: 1, name: b1}]\n",
      "lec6.yaml");
  EXPECT_EQ(c.lines[0].axes[0].alarm_polarity, lec::AlarmPolarity::ActiveLow);
  EXPECT_EQ(c.lines[0].axes[1].alarm_polarity, lec::AlarmPolarity::ActiveHigh);
  EXPECT_EQ(c.lines[1].axes[0].alarm_polarity, lec::AlarmPolarity::ActiveHigh);
  EXPECT_EQ(error_of("lines:\n  - port: sim\n    axes: [{id: 1, alarm_polarity: inverted}]\n"),
            "lec6.yaml:3: lines[0].axes[0].alarm_polarity: 'inverted' is not an alarm polarity: "
            "active-high (the manual: X4F = 1 is an alarm) or active-low (X4F = 0 is an alarm)");
  EXPECT_THAT(error_of("lines:\n  - port: sim\n    alarm_polarity: low\n    axes: [{id: 1}]\n"),
              HasSubstr("lec6.yaml:3: lines[0].alarm_polarity: 'low' is not an alarm polarity"));
  FlagConfig f;
  f.port = "sim";
  f.ids = "1-2";
  f.alarm_polarity = lec::AlarmPolarity::ActiveLow;
  const ServeConfig from_flags =
      config_from_flags(f);  // kept: a range-for over a temporary's member dangles
  for (const auto& a : from_flags.lines[0].axes) {
    EXPECT_EQ(a.alarm_polarity, lec::AlarmPolarity::ActiveLow);
  }
}

// A sim line's twin: the profile named (ideal, default, or a file over the
// default); a file that cannot be read is a config error naming it.
TEST(ServeConfig, SimProfile) {
  const auto ideal = parse_config(
      "lines:\n  - port: sim\n    sim: {profile: ideal}\n"
      "    axes: [{id: 1}]\n",
      "lec6.yaml");
  EXPECT_EQ(ideal.lines[0].sim.actuator.busy_delay, sim::ideal_config().busy_delay);
  const auto def = parse_config(
      "lines:\n  - port: sim\n    sim: {profile: default}\n"
      "    axes: [{id: 1}]\n",
      "lec6.yaml");
  EXPECT_EQ(def.lines[0].sim.actuator.busy_delay, sim::default_config().busy_delay);
  // No profile named: lec sim's default twin, also from flags; --sim-profile ideal.
  const auto none = parse_config("lines:\n  - port: sim\n    axes: [{id: 1}]\n", "lec6.yaml");
  EXPECT_EQ(none.lines[0].sim.actuator.busy_delay, sim::default_config().busy_delay);
  FlagConfig f;
  f.port = "sim";
  EXPECT_EQ(config_from_flags(f).lines[0].sim.actuator.busy_delay,
            sim::default_config().busy_delay);
  f.sim_profile = "ideal";
  EXPECT_EQ(config_from_flags(f).lines[0].sim.actuator.busy_delay, Duration::zero());
  f.sim_profile = "/nonexistent/p.yaml";
  EXPECT_THROW(config_from_flags(f), ConfigError);
  EXPECT_THAT(error_of("lines:\n  - port: sim\n    sim: {profile: /nonexistent/p.yaml}\n"
                       "    axes: [{id: 1}]\n"),
              HasSubstr("lines[0].sim.profile: default, ideal or a field profile file: "
                        "/nonexistent/p.yaml: cannot read the profile"));
}

TEST(ServeConfig, AMissingFileIsNamed) {
  try {
    load_config("/nonexistent/lec6.yaml");
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_THAT(e.what(), HasSubstr("cannot read the config file /nonexistent/lec6.yaml"));
  }
}

TEST(ServeConfig, FlagsMakeTheSimpleCase) {
  FlagConfig f;
  f.port = "/dev/ttyUSB0";
  f.ids = "1-3,7";
  const auto c = config_from_flags(f);
  ASSERT_EQ(c.lines[0].axes.size(), 4u);
  EXPECT_EQ(c.lines[0].axes[3].name, "axis7");
  EXPECT_EQ(c.lines[0].modbus_tcp->listen.text(), "127.0.0.1:1502");
  EXPECT_EQ(c.http->listener.listen.text(), "127.0.0.1:8080");
  EXPECT_THROW(parse_ids("0-3"), ConfigError);
  EXPECT_THROW(parse_ids("4-2"), ConfigError);
  EXPECT_THROW(parse_ids("x"), ConfigError);
  f.http = "0.0.0.0:8080";
  EXPECT_THROW(config_from_flags(f), ConfigError);  // no token
  f.token = "s3cret";
  EXPECT_NO_THROW(config_from_flags(f));
}

TEST(ServeConfig, MqttSection) {
  const char* lines = "lines:\n  - port: sim\n    axes: [{id: 1}]\n";
  auto c = parse_config(std::string(lines) + "mqtt: true\n", "lec6.yaml");
  ASSERT_TRUE(c.mqtt);  // the embedded default: the local broker
  EXPECT_EQ(c.mqtt->broker, "mqtt://127.0.0.1:1883");
  EXPECT_EQ(c.mqtt->prefix, "lec6");
  EXPECT_EQ(c.mqtt->telemetry_hz, 5);
  EXPECT_EQ(c.mqtt->command_valid_for_s, 5);
  EXPECT_EQ(c.mqtt->keepalive_s, 30u);
  EXPECT_FALSE(parse_config(std::string(lines) + "mqtt: false\n", "lec6.yaml").mqtt);
  c = parse_config(std::string(lines) +
                       "mqtt:\n  broker: mqtt://[::1]:11883\n  client_id: cell7\n"
                       "  bridge: cell7\n  prefix: plant/hall3\n  username: u\n  password: p\n"
                       "  telemetry_hz: 20\n  command_valid_for_s: 2\n  home_assistant: true\n"
                       "  keepalive_s: 10\n  reconnect_max_s: 5\n",
                   "lec6.yaml");
  EXPECT_EQ(c.mqtt->url().port, 11883);
  EXPECT_EQ(c.mqtt->prefix, "plant/hall3");
  EXPECT_EQ(c.mqtt->telemetry_hz, 20);
  EXPECT_TRUE(c.mqtt->home_assistant);
  EXPECT_EQ(c.mqtt->reconnect_max_s, 5u);
}

TEST(ServeConfig, MqttMistakesNameTheKey) {
  const std::string lines = "lines:\n  - port: sim\n    axes: [{id: 1}]\n";
  EXPECT_EQ(error_of(lines + "mqtt:\n  broker: tcp://h:1883\n"),
            "lec6.yaml:5: mqtt.broker: 'tcp://h:1883': expected mqtt://host[:port] or "
            "mqtts://host[:port]");
  EXPECT_THAT(error_of(lines + "mqtt:\n  broker: mqtt://h:99999\n"),
              HasSubstr("mqtt.broker: 'mqtt://h:99999': the port must be 1 to 65535"));
  EXPECT_THAT(error_of(lines + "mqtt:\n  prefix: lec6/#\n"),
              HasSubstr("lec6.yaml:5: mqtt.prefix: 'lec6/#' has a wildcard"));
  EXPECT_THAT(error_of(lines + "mqtt:\n  bridge: 'a/b'\n"), HasSubstr("mqtt.bridge"));
  EXPECT_THAT(error_of(lines + "mqtt:\n  password: p\n"),
              HasSubstr("mqtt.password: a password needs a username"));
  EXPECT_THAT(error_of(lines + "mqtt:\n  ca_file: /etc/hostname\n"),
              HasSubstr("mqtt.ca_file: TLS files need an mqtts:// broker"));
  EXPECT_THAT(error_of(lines + "mqtt:\n  broker: mqtts://h\n  ca_file: /nonexistent/ca.crt\n"),
              HasSubstr("mqtt.ca_file: cannot read '/nonexistent/ca.crt'"));
  EXPECT_THAT(error_of(lines + "mqtt:\n  broker: mqtts://h\n  cert_file: /etc/hostname\n"),
              HasSubstr("mqtt.cert_file: a client certificate needs both cert_file and key_file"));
  EXPECT_THAT(error_of(lines + "mqtt:\n  telemetry_hz: 0\n"), HasSubstr("mqtt.telemetry_hz"));
  EXPECT_THAT(error_of(lines + "mqtt:\n  keepalive_s: 2\n"),
              HasSubstr("mqtt.keepalive_s: 2 is not 5 to 65535 s"));
  EXPECT_THAT(error_of(lines + "mqtt:\n  telemetry: 5\n"),
              HasSubstr("mqtt.telemetry: unknown key: did you mean 'telemetry_hz'?"));
}

TEST(ServeConfig, Endpoints) {
  EXPECT_TRUE(parse_endpoint("127.0.0.1:1502").loopback());
  EXPECT_TRUE(parse_endpoint("[::1]:1502").loopback());
  EXPECT_FALSE(parse_endpoint("0.0.0.0:1502").loopback());
  EXPECT_EQ(parse_endpoint(":1502").address, "127.0.0.1");
  EXPECT_THROW(parse_endpoint("1502"), ConfigError);
  EXPECT_THROW(parse_endpoint("host:99999"), ConfigError);
}

}  // namespace
}  // namespace lec6::serve
