#pragma once
// What `lec serve` runs: its lines, their axes, and the listeners of every
// front-end. Read from YAML (`lec serve --config lec6.yaml`, yaml-cpp) or
// made from flags for the simple case (`lec serve --port /dev/ttyUSB0 --ids 1-4`).
// docs/serve.md shows every key with its default.
//
// A mistake names the file, the line in it, the key and the rule it breaks:
//   lec6.yaml:14: lines[0].axes[1].id: 300 is not a controller ID (1 to 255, digest §2)
// Nothing runs with a config that has an error.
//
// Thread safety: plain values.

#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "lec6/clock.hpp"
#include "lec6/error.hpp"
#include "lec6/lec/alarm_check.hpp"
#include "lec6/sim/behaviour.hpp"

namespace lec6::serve {

// A machine cycle lec serve runs (serve/cycles/served_cycle.hpp).
struct ServedCycle;

class ConfigError : public InvalidArgument {
 public:
  using InvalidArgument::InvalidArgument;
};

struct Endpoint {
  std::string address = "127.0.0.1";
  uint16_t port = 0;
  bool loopback() const;
  std::string text() const;  // "127.0.0.1:1502", "[::1]:1502"
};

struct ListenerConfig {
  Endpoint listen;
  bool read_only = false;  // writes get exception 01 / HTTP 403
  // Modbus TCP / RTU over TCP: a client's FC06 (write one register) is
  // written as the equivalent one-register FC10 and answered as FC06 (its
  // echo): lec6's extension, the controller itself refuses FC06
  // (docs/protocol-decisions.md). false: exception 01, as the controller.
  bool fc06 = true;
};

struct AxisConfig {
  uint8_t id = 1;
  std::string name;          // unique across lines; "axis<ID>" by default
  double telemetry_hz = 10;  // 0: no telemetry polling
  // soft_limits_mm: [MIN, MAX]: moves to a target outside are refused before
  // anything is written (client::SoftLimits). Empty: none.
  std::optional<std::pair<int32_t, int32_t>> soft_limits_001mm;
  // A stop the axis did not obey (still moving after HOLD too) turns the
  // servo off (client::StopPolicy::escalate_servo_off). Off by default: with
  // the servo off a vertical axis may drop; say so where it is safe.
  bool stop_servo_off = false;
  // How this controller reports X4F ALARM (`alarm_polarity:` of the axis, or
  // of its line for all its axes): active-high (the manual: 1 = alarm) or
  // active-low. Everything lec serve derives from ALARM (status JSON, SSE,
  // MQTT, Sparkplug, the move history) reads X4F through
  // lec::normalise_alarm with it; the Modbus TCP gateway passes the wire's
  // bits unchanged (tests/serve/ops/alarm_polarity_test.cpp).
  lec::AlarmPolarity alarm_polarity = lec::AlarmPolarity::ActiveHigh;
};

struct Rs485Config {
  bool enabled = false;
  bool rts_after_send = false;
  uint32_t delay_before_ms = 0;
  uint32_t delay_after_ms = 0;
};

// The built-in twin behind a `port: sim` line.
struct SimLineConfig {
  // `profile:` default (the twin of `lec sim`: the field's evidence,
  // sim::default_config()), ideal (the manual's, `lec sim --ideal`), or a
  // field profile file read over the default (twin/field_profile.hpp). The
  // keys below (stroke, position, workpiece, wear) override it.
  std::string profile = "default";
  sim::ActuatorConfig actuator = sim::default_config();
  bool fast = false;  // timing: fast (no line delays) or real (default)
  std::optional<double> workpiece_mm;
  double stroke_max_mm = 400;
  double initial_position_mm = 10;
  double drop_rate = 0, corrupt_rate = 0, garbage_rate = 0;
  uint64_t seed = 1;
  // Axes configured on the line but not on the twin: a dead ID (nothing answers).
  std::set<uint8_t> absent_ids;
  double wear_pct_per_m = 0;  // sim::ActuatorConfig::wear_pct_per_m (docs/history.md)
};

struct LineConfig {
  std::string name;
  std::string port;  // /dev/ttyUSB0, sim, rtu+tcp://host:port
  uint32_t baud = 38400;
  unsigned silent_interval = 1;  // k: Ts = k × 3.5 chars
  double delay_ms = 5;           // Td
  double timeout_margin_ms = 50;
  int retries = 2;  // reads from clients, after a lost reply
  bool echo = false;
  // Wait Ts of silence before each query (manual §8.2). Only a twin in fast
  // timing (or a benchmark of software costs) may do without: never on RS485.
  bool silence_wait = true;
  Rs485Config rs485;
  SimLineConfig sim;
  std::vector<AxisConfig> axes;
  // A state read may be answered from the telemetry cache when no older than
  // this; default (nullopt): twice the slowest telemetry period, at least 100 ms.
  std::optional<double> cache_max_age_ms;
  unsigned offline_after = 3;
  double probe_interval_ms = 2000;
  // A poll (move completion, telemetry, probe) that waited this long takes
  // turns with client commands (scheduler.hpp).
  double poll_max_wait_ms = 100;
  bool allow_broadcast = false;  // unit id 0 from Modbus TCP: a broadcast write
  std::optional<ListenerConfig> modbus_tcp;
  std::optional<ListenerConfig> rtu_tcp;
  // `lec serve --record FILE`: every frame of this line into a capture file
  // (docs/capture-format.md); empty: none.
  std::string record;

  Duration cache_max_age() const;
};

struct HttpConfig {
  ListenerConfig listener;
  std::string token;               // required for writes when the listener is not loopback
  std::filesystem::path web_root;  // the dashboard's files; empty: beside the binary
};

// Where the MQTT bridge connects: mqtt://host[:1883] or mqtts://host[:8883]
// (TLS). IPv6 addresses in brackets: mqtt://[::1]:1883.
struct BrokerUrl {
  bool tls = false;
  std::string host;
  uint16_t port = 1883;
};
// Throws std::invalid_argument saying what is wrong.
BrokerUrl parse_broker_url(const std::string& text);

// The MQTT bridge (docs/mqtt.md): telemetry out, commands in, one broker.
struct MqttConfig {
  std::string broker = "mqtt://127.0.0.1:1883";
  std::string client_id;  // default: lec6-<host name>
  std::string bridge;     // the name in PREFIX/<bridge>/status; default: the client id
  std::string prefix = "lec6";
  std::string username, password;
  std::filesystem::path ca_file, cert_file, key_file;  // TLS (mqtts://)
  double telemetry_hz = 5;                             // state messages per axis per second
  double command_valid_for_s = 5;                      // older commands are refused
  bool home_assistant = false;                         // MQTT discovery
  unsigned keepalive_s = 30;      // the broker gives up on us after 1.5 × this
  unsigned reconnect_max_s = 30;  // back-off doubles from 1 s up to this

  BrokerUrl url() const { return parse_broker_url(broker); }
};

// The move history, odometer and drift warnings (docs/history.md).
struct HistoryConfig {
  std::filesystem::path state_dir;  // history.db lives here; empty: the default (docs/history.md)
  double max_age_days = 365;
  double max_size_mb = 100;
  unsigned queue = 4096;  // records waiting for the disk; beyond: dropped and counted
  double drift_threshold_pct = 10;
  unsigned drift_baseline_moves = 20;
  double drift_tolerance_mm = 0.5;
  struct Service {
    std::string what;  // "lubricate"
    std::optional<double> every_km, every_moves, every_hours;
  };
  std::vector<Service> services;
};

// lec serve as a Sparkplug B edge node (docs/sparkplug.md): the node is the
// daemon, each axis a device. Beside the MQTT bridge or instead of it.
struct SparkplugConfig {
  std::string broker = "mqtt://127.0.0.1:1883";
  std::string group_id = "lec6";
  std::string edge_node_id;     // default: the host name
  std::string client_id;        // default: lec6-sparkplug-<edge node id>
  std::string primary_host_id;  // births wait for this host's STATE online; empty: none
  std::string username, password;
  std::filesystem::path ca_file, cert_file, key_file;  // TLS (mqtts://)
  double telemetry_hz = 10;  // values compared per second (report by exception)
  unsigned keepalive_s = 30;
  unsigned reconnect_max_s = 30;
  // Where bdSeq is kept across restarts; default: sparkplug-GROUP-NODE.bdseq
  // in the history's state_dir when the history is on, else none (bdSeq starts at 0).
  std::filesystem::path bdseq_file;

  BrokerUrl url() const { return parse_broker_url(broker); }
};
// nullopt when `id` may be a Sparkplug group, edge node or device id; else why not.
std::optional<std::string> check_sparkplug_id(const std::string& id);

struct ServeConfig {
  std::string source;  // the file read, or "command line"
  std::vector<LineConfig> lines;
  std::optional<HttpConfig> http;
  std::optional<MqttConfig> mqtt;
  std::optional<HistoryConfig> history;  // issue 26
  bool history_off = false;  // `history: false`: none, not even in the default directory
  std::optional<SparkplugConfig> sparkplug;  // issue 35
  // Machine cycles it runs on its axes (issue 34: `cycles:`, `lec serve
  // --cycles PATH`; docs/cycles.md "Through lec serve"): each file read and
  // its axes matched to this config's when the config is read.
  std::vector<std::shared_ptr<const ServedCycle>> cycles;

  // The axis called `name`, with its line; nullopt when there is none.
  struct Found {
    const LineConfig* line;
    const AxisConfig* axis;
  };
  std::optional<Found> find_axis(std::string_view name) const;
};

// Reads and checks a config file. Throws ConfigError naming file and line.
ServeConfig load_config(const std::filesystem::path& file);
// The same from text (tests; `source` names it in messages).
ServeConfig parse_config(const std::string& text, const std::string& source);

// `lec serve --port P --ids 1-4`: one line, Modbus TCP on 127.0.0.1:1502 and
// HTTP on 127.0.0.1:8080 unless told otherwise.
struct FlagConfig {
  std::string port;
  std::string ids = "1";
  uint32_t baud = 38400;
  double telemetry_hz = 10;
  std::string modbus_tcp = "127.0.0.1:1502";  // empty: none
  std::string rtu_tcp;                        // empty: none
  std::string http = "127.0.0.1:8080";        // empty: none
  std::string token;
  bool fast_sim = false;
  std::string state_dir;                                               // empty: no move history
  lec::AlarmPolarity alarm_polarity = lec::AlarmPolarity::ActiveHigh;  // every axis's
  std::string sim_profile = "default";  // port sim: SimLineConfig::profile (`lec --sim-profile`)
};
ServeConfig config_from_flags(const FlagConfig& flags);
// `lec serve --cycles PATH`: the cycle file, or every *.yaml and *.yml of the
// directory, added to config.cycles (its axes matched to the config's).
// Throws ConfigError naming the file, the line and the field.
void add_cycles(ServeConfig& config, const std::filesystem::path& path);

// "1-4,7" → {1,2,3,4,7}; throws ConfigError naming what is wrong.
std::vector<uint8_t> parse_ids(const std::string& text);
// "127.0.0.1:1502", "[::1]:1502", ":1502" (loopback); throws ConfigError.
Endpoint parse_endpoint(const std::string& text);

}  // namespace lec6::serve
