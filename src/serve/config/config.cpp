// The serve config from YAML, with every mistake named by file, line and key.

#include "lec6/serve/config.hpp"
#include "lec6/error.hpp"

#include <arpa/inet.h>
#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <set>

#include "config/config_reader.hpp"
#include "cycles/cycles_config.hpp"    // issue 34: the cycles: section
#include "history/config_history.hpp"  // issue 26: the history: section
#include "lec6/modbus/timing.hpp"
#include "lec6/serve/mqtt_topics.hpp"
#include "lec6/transport/port_spec.hpp"
#include "lec6/twin/field_profile.hpp"

namespace lec6::serve {
namespace {

void read_listener(const Reader& r, const YAML::Node& n, const std::string& path,
                   std::optional<ListenerConfig>& out, uint16_t default_port) {
  if (!n) return;
  if (n.IsScalar() && !n.as<bool>(true)) return;  // `modbus_tcp: false`
  r.keys(n, path, {"listen", "read_only", "fc06"});
  ListenerConfig l;
  l.listen = r.endpoint(n["listen"], path + ".listen", fmt::format("127.0.0.1:{}", default_port));
  l.read_only = r.get<bool>(n["read_only"], path + ".read_only", false);
  l.fc06 = r.get<bool>(n["fc06"], path + ".fc06", true);
  out = l;
}

SimLineConfig read_sim(const Reader& r, const YAML::Node& n, const std::string& path) {
  SimLineConfig s;
  if (!n) return s;
  r.keys(n, path,
         {"profile", "timing", "workpiece_mm", "stroke_max_mm", "initial_position_mm", "drop_rate",
          "corrupt_rate", "garbage_rate", "seed", "absent_ids", "wear_pct_per_m"});
  s.profile = r.get<std::string>(n["profile"], path + ".profile", s.profile);
  try {
    s.actuator = twin::named_profile(s.profile).actuator;
  } catch (const twin::ProfileError& e) {
    r.fail(n["profile"], path + ".profile",
           fmt::format("default, ideal or a field profile file: {}", e.what()));
  }
  const std::string timing = r.get<std::string>(n["timing"], path + ".timing", "real");
  if (timing != "real" && timing != "fast") {
    r.fail(n["timing"], path + ".timing", fmt::format("'{}' is not real or fast", timing));
  }
  s.fast = timing == "fast";
  if (n["workpiece_mm"])
    s.workpiece_mm = r.get<double>(n["workpiece_mm"], path + ".workpiece_mm", 0);
  if (!n["workpiece_mm"]) s.workpiece_mm = s.actuator.workpiece_mm;
  s.stroke_max_mm =
      r.number(n["stroke_max_mm"], path + ".stroke_max_mm", s.actuator.stroke_max_mm, 1, 100000);
  s.initial_position_mm = r.number(n["initial_position_mm"], path + ".initial_position_mm",
                                   s.actuator.initial_position_mm, 0, s.stroke_max_mm);
  s.drop_rate = r.number(n["drop_rate"], path + ".drop_rate", 0, 0, 1);
  s.corrupt_rate = r.number(n["corrupt_rate"], path + ".corrupt_rate", 0, 0, 1);
  s.garbage_rate = r.number(n["garbage_rate"], path + ".garbage_rate", 0, 0, 1);
  s.seed = r.get<uint64_t>(n["seed"], path + ".seed", 1);
  if (const auto absent = n["absent_ids"]) {
    if (!absent.IsSequence()) {
      r.fail(absent, path + ".absent_ids", "a list of controller IDs, e.g. [9]");
    }
    for (std::size_t i = 0; i < absent.size(); ++i) {
      s.absent_ids.insert(static_cast<uint8_t>(
          r.number(absent[i], fmt::format("{}.absent_ids[{}]", path, i), 1, 1, 255)));
    }
  }
  s.wear_pct_per_m =
      r.number(n["wear_pct_per_m"], path + ".wear_pct_per_m", s.actuator.wear_pct_per_m, 0, 1000);
  return s;
}

// `alarm_polarity:` (a line's, or an axis's over it), as lec --alarm-polarity.
lec::AlarmPolarity read_alarm_polarity(const Reader& r, const YAML::Node& n,
                                       const std::string& path, lec::AlarmPolarity fallback) {
  if (!n || n.IsNull()) return fallback;
  const std::string text = r.get<std::string>(n, path, "");
  const auto p = lec::parse_alarm_polarity(text);
  if (!p) {
    r.fail(n, path,
           fmt::format("'{}' is not an alarm polarity: active-high (the manual: X4F = 1 is an "
                       "alarm) or active-low (X4F = 0 is an alarm)",
                       text));
  }
  return *p;
}

AxisConfig read_axis(const Reader& r, const YAML::Node& n, const std::string& path,
                     lec::AlarmPolarity line_polarity) {
  r.keys(n, path,
         {"id", "name", "telemetry_hz", "soft_limits_mm", "stop_servo_off", "alarm_polarity"});
  AxisConfig a;
  if (!n["id"]) r.fail(n, path, "every axis needs an id (the controller ID, 1 to 255)");
  a.id = static_cast<uint8_t>(
      r.integer(n["id"], path + ".id", 1, 1, 255, "a controller ID (1 to 255, digest §2)"));
  a.name = r.get<std::string>(n["name"], path + ".name", fmt::format("axis{}", a.id));
  r.name(n["name"], path + ".name", a.name);
  a.telemetry_hz = r.number(n["telemetry_hz"], path + ".telemetry_hz", 10, 0, 1000);
  if (const auto l = n["soft_limits_mm"]) {
    const std::string at = path + ".soft_limits_mm";
    if (!l.IsSequence() || l.size() != 2) r.fail(l, at, "expected [MIN, MAX] in mm, e.g. [0, 400]");
    const auto end = [&](std::size_t i) {
      return static_cast<int32_t>(std::lround(r.number(l[i], at, 0, -2e7, 2e7) * 100));
    };
    a.soft_limits_001mm = std::pair{end(0), end(1)};
    if (a.soft_limits_001mm->first > a.soft_limits_001mm->second) r.fail(l, at, "MIN is above MAX");
  }
  a.stop_servo_off = r.get<bool>(n["stop_servo_off"], path + ".stop_servo_off", false);
  a.alarm_polarity =
      read_alarm_polarity(r, n["alarm_polarity"], path + ".alarm_polarity", line_polarity);
  return a;
}

void check_port(const Reader& r, const YAML::Node& n, const std::string& path,
                const std::string& port) {
  try {
    const auto spec = transport::parse_port_spec(port);
    if (spec.kind == transport::PortKind::Tcp) {
      r.fail(n, path,
             fmt::format("'{}' is Modbus TCP: a line is driven in Modbus RTU, on a serial port, "
                         "sim, or rtu+tcp://host:port",
                         port));
    }
  } catch (const InvalidArgument& e) {
    r.fail(n, path, e.what());
  }
}

LineConfig read_line(const Reader& r, const YAML::Node& n, const std::string& path) {
  r.keys(n, path,
         {"name",
          "port",
          "baud",
          "silent_interval",
          "delay_ms",
          "timeout_margin_ms",
          "retries",
          "echo",
          "silence_wait",
          "rs485",
          "sim",
          "axes",
          "cache_max_age_ms",
          "offline_after",
          "probe_interval_ms",
          "poll_max_wait_ms",
          "allow_broadcast",
          "modbus_tcp",
          "rtu_tcp",
          "alarm_polarity"});
  LineConfig l;
  if (!n["port"])
    r.fail(n, path, "every line needs a port: /dev/ttyUSB0, sim, or rtu+tcp://host:port");
  l.port = r.get<std::string>(n["port"], path + ".port", "");
  check_port(r, n["port"], path + ".port", l.port);
  l.name = r.get<std::string>(n["name"], path + ".name", "");
  r.name(n["name"], path + ".name", l.name);
  const int baud =
      static_cast<int>(r.integer(n["baud"], path + ".baud", 38400, 1, 1000000, "a baud rate"));
  if (!modbus::is_supported_baud(static_cast<uint32_t>(baud))) {
    r.fail(n["baud"], path + ".baud",
           fmt::format("{} is not a baud rate the controller has (9600, 19200, 38400, 57600, "
                       "115200, 230400)",
                       baud));
  }
  l.baud = static_cast<uint32_t>(baud);
  l.silent_interval = static_cast<unsigned>(
      r.integer(n["silent_interval"], path + ".silent_interval", 1, 1, 100, "k (1 to 100)"));
  l.delay_ms = r.number(n["delay_ms"], path + ".delay_ms", 5, 0, 1000);
  l.timeout_margin_ms = r.number(n["timeout_margin_ms"], path + ".timeout_margin_ms", 50, 0, 60000);
  l.retries = static_cast<int>(r.integer(n["retries"], path + ".retries", 2, 0, 10, "0 to 10"));
  l.echo = r.get<bool>(n["echo"], path + ".echo", false);
  l.silence_wait = r.get<bool>(n["silence_wait"], path + ".silence_wait", true);
  if (const auto rs = n["rs485"]) {
    r.keys(rs, path + ".rs485", {"enabled", "rts_after_send", "delay_before_ms", "delay_after_ms"});
    l.rs485.enabled = r.get<bool>(rs["enabled"], path + ".rs485.enabled", true);
    l.rs485.rts_after_send =
        r.get<bool>(rs["rts_after_send"], path + ".rs485.rts_after_send", false);
    l.rs485.delay_before_ms = static_cast<uint32_t>(
        r.integer(rs["delay_before_ms"], path + ".rs485.delay_before_ms", 0, 0, 1000, "0 to 1000"));
    l.rs485.delay_after_ms = static_cast<uint32_t>(
        r.integer(rs["delay_after_ms"], path + ".rs485.delay_after_ms", 0, 0, 1000, "0 to 1000"));
  }
  l.sim = read_sim(r, n["sim"], path + ".sim");
  if (n["sim"] && l.port != "sim") r.fail(n["sim"], path + ".sim", "sim settings need port: sim");
  if (n["cache_max_age_ms"]) {
    l.cache_max_age_ms = r.number(n["cache_max_age_ms"], path + ".cache_max_age_ms", 0, 0, 60000);
  }
  l.offline_after = static_cast<unsigned>(
      r.integer(n["offline_after"], path + ".offline_after", 3, 1, 100, "1 to 100"));
  l.probe_interval_ms =
      r.number(n["probe_interval_ms"], path + ".probe_interval_ms", 2000, 10, 3.6e6);
  l.poll_max_wait_ms = r.number(n["poll_max_wait_ms"], path + ".poll_max_wait_ms", 100, 0, 60000);
  l.allow_broadcast = r.get<bool>(n["allow_broadcast"], path + ".allow_broadcast", false);
  read_listener(r, n["modbus_tcp"], path + ".modbus_tcp", l.modbus_tcp, 1502);
  read_listener(r, n["rtu_tcp"], path + ".rtu_tcp", l.rtu_tcp, 1503);
  const auto axes = n["axes"];
  if (!axes || !axes.IsSequence() || axes.size() == 0) {
    r.fail(axes ? axes : n, path + ".axes", "a line needs a list of axes (at least one id)");
  }
  const lec::AlarmPolarity polarity = read_alarm_polarity(
      r, n["alarm_polarity"], path + ".alarm_polarity", lec::AlarmPolarity::ActiveHigh);
  std::set<int> ids;
  for (std::size_t i = 0; i < axes.size(); ++i) {
    const std::string ap = fmt::format("{}.axes[{}]", path, i);
    AxisConfig a = read_axis(r, axes[i], ap, polarity);
    if (!ids.insert(a.id).second) {
      r.fail(axes[i]["id"], ap + ".id", fmt::format("ID {} is already an axis of this line", a.id));
    }
    l.axes.push_back(std::move(a));
  }
  return l;
}

std::optional<HttpConfig> read_http(const Reader& r, const YAML::Node& n) {
  if (!n) return std::nullopt;
  if (n.IsScalar() && !n.as<bool>(true)) return std::nullopt;
  r.keys(n, "http", {"listen", "read_only", "token", "web_root"});
  HttpConfig h;
  h.listener.listen = r.endpoint(n["listen"], "http.listen", "127.0.0.1:8080");
  h.listener.read_only = r.get<bool>(n["read_only"], "http.read_only", false);
  h.token = r.get<std::string>(n["token"], "http.token", "");
  h.web_root = r.get<std::string>(n["web_root"], "http.web_root", "");
  if (!h.listener.listen.loopback() && h.token.empty() && !h.listener.read_only) {
    r.fail(n["listen"], "http.listen",
           fmt::format("{} is reachable from other machines: set http.token (writes need it) or "
                       "read_only: true",
                       h.listener.listen.text()));
  }
  return h;
}

void check_mqtt_files(const Reader& r, const YAML::Node& n, const MqttConfig& m, bool tls) {
  for (const char* key : {"ca_file", "cert_file", "key_file"}) {
    const std::string path = std::string("mqtt.") + key;
    const std::string file = r.get<std::string>(n[key], path, "");
    if (file.empty()) continue;
    if (!tls) r.fail(n[key], path, "TLS files need an mqtts:// broker");
    std::error_code ec;
    if (!std::filesystem::is_regular_file(file, ec)) {
      r.fail(n[key], path, fmt::format("cannot read '{}': no such file", file));
    }
  }
  if (m.cert_file.empty() != m.key_file.empty()) {
    const char* given = m.cert_file.empty() ? "key_file" : "cert_file";
    r.fail(n[given], std::string("mqtt.") + given,
           "a client certificate needs both cert_file and key_file");
  }
}

std::optional<MqttConfig> read_mqtt(const Reader& r, const YAML::Node& n) {
  if (!n) return std::nullopt;
  if (n.IsScalar() && !n.as<bool>(true)) return std::nullopt;
  if (n.IsScalar()) return MqttConfig{};  // `mqtt: true`: the local broker
  r.keys(n, "mqtt",
         {"broker", "client_id", "bridge", "prefix", "username", "password", "ca_file", "cert_file",
          "key_file", "telemetry_hz", "command_valid_for_s", "home_assistant", "keepalive_s",
          "reconnect_max_s"});
  MqttConfig m;
  m.broker = r.get<std::string>(n["broker"], "mqtt.broker", m.broker);
  BrokerUrl url;
  try {
    url = parse_broker_url(m.broker);
  } catch (const std::invalid_argument& e) {
    r.fail(n["broker"], "mqtt.broker", e.what());
  }
  m.client_id = r.get<std::string>(n["client_id"], "mqtt.client_id", "");
  if (n["client_id"] && m.client_id.empty()) {
    r.fail(n["client_id"], "mqtt.client_id", "empty: leave it out for lec6-<host name>");
  }
  m.bridge = r.get<std::string>(n["bridge"], "mqtt.bridge", "");
  if (n["bridge"]) r.name(n["bridge"], "mqtt.bridge", m.bridge);
  m.prefix = r.get<std::string>(n["prefix"], "mqtt.prefix", m.prefix);
  if (const auto why = check_topic_prefix(m.prefix)) r.fail(n["prefix"], "mqtt.prefix", *why);
  m.username = r.get<std::string>(n["username"], "mqtt.username", "");
  m.password = r.get<std::string>(n["password"], "mqtt.password", "");
  if (!m.password.empty() && m.username.empty()) {
    r.fail(n["password"], "mqtt.password", "a password needs a username");
  }
  m.ca_file = r.get<std::string>(n["ca_file"], "mqtt.ca_file", "");
  m.cert_file = r.get<std::string>(n["cert_file"], "mqtt.cert_file", "");
  m.key_file = r.get<std::string>(n["key_file"], "mqtt.key_file", "");
  check_mqtt_files(r, n, m, url.tls);
  m.telemetry_hz = r.number(n["telemetry_hz"], "mqtt.telemetry_hz", 5, 0.01, 1000);
  m.command_valid_for_s =
      r.number(n["command_valid_for_s"], "mqtt.command_valid_for_s", 5, 0.1, 3600);
  m.home_assistant = r.get<bool>(n["home_assistant"], "mqtt.home_assistant", false);
  // libmosquitto refuses a keepalive under 5 s.
  m.keepalive_s = static_cast<unsigned>(
      r.integer(n["keepalive_s"], "mqtt.keepalive_s", 30, 5, 65535, "5 to 65535 s"));
  m.reconnect_max_s = static_cast<unsigned>(
      r.integer(n["reconnect_max_s"], "mqtt.reconnect_max_s", 30, 1, 3600, "1 to 3600 s"));
  return m;
}

// issue 35: the sparkplug: section (docs/sparkplug.md).
std::optional<SparkplugConfig> read_sparkplug(const Reader& r, const YAML::Node& n) {
  if (!n) return std::nullopt;
  if (n.IsScalar() && !n.as<bool>(true)) return std::nullopt;
  if (n.IsScalar()) return SparkplugConfig{};
  r.keys(n, "sparkplug",
         {"broker", "group_id", "edge_node_id", "client_id", "primary_host_id", "username",
          "password", "ca_file", "cert_file", "key_file", "telemetry_hz", "keepalive_s",
          "reconnect_max_s", "bdseq_file"});
  SparkplugConfig s;
  s.broker = r.get<std::string>(n["broker"], "sparkplug.broker", s.broker);
  BrokerUrl url;
  try {
    url = parse_broker_url(s.broker);
  } catch (const std::invalid_argument& e) {
    r.fail(n["broker"], "sparkplug.broker", e.what());
  }
  for (auto [key, out] : {std::pair{"group_id", &s.group_id},
                          {"edge_node_id", &s.edge_node_id},
                          {"primary_host_id", &s.primary_host_id}}) {
    *out = r.get<std::string>(n[key], std::string("sparkplug.") + key, *out);
    if (!n[key]) continue;
    if (const auto why = check_sparkplug_id(*out))
      r.fail(n[key], std::string("sparkplug.") + key, *why);
  }
  s.client_id = r.get<std::string>(n["client_id"], "sparkplug.client_id", "");
  s.username = r.get<std::string>(n["username"], "sparkplug.username", "");
  s.password = r.get<std::string>(n["password"], "sparkplug.password", "");
  if (!s.password.empty() && s.username.empty()) {
    r.fail(n["password"], "sparkplug.password", "a password needs a username");
  }
  for (auto [key, out] :
       {std::pair{"ca_file", &s.ca_file}, {"cert_file", &s.cert_file}, {"key_file", &s.key_file}}) {
    *out = r.get<std::string>(n[key], std::string("sparkplug.") + key, "");
    if (out->empty()) continue;
    if (!url.tls)
      r.fail(n[key], std::string("sparkplug.") + key, "TLS files need an mqtts:// broker");
    std::error_code ec;
    if (!std::filesystem::is_regular_file(*out, ec)) {
      r.fail(n[key], std::string("sparkplug.") + key,
             fmt::format("cannot read '{}': no such file", out->string()));
    }
  }
  s.telemetry_hz = r.number(n["telemetry_hz"], "sparkplug.telemetry_hz", 10, 0.1, 1000);
  s.keepalive_s = static_cast<unsigned>(
      r.integer(n["keepalive_s"], "sparkplug.keepalive_s", 30, 5, 65535, "5 to 65535 s"));
  s.reconnect_max_s = static_cast<unsigned>(
      r.integer(n["reconnect_max_s"], "sparkplug.reconnect_max_s", 30, 1, 3600, "1 to 3600 s"));
  s.bdseq_file = r.get<std::string>(n["bdseq_file"], "sparkplug.bdseq_file", "");
  return s;
}

// Names are unique across the whole daemon: /api/axes/{name} and MQTT
// topics address axes by name alone.
void check_unique_names(const Reader& r, const YAML::Node& root, const ServeConfig& c) {
  std::set<std::string> lines, axes;
  for (std::size_t i = 0; i < c.lines.size(); ++i) {
    const auto node = root["lines"][i];
    if (!lines.insert(c.lines[i].name).second) {
      r.fail(node["name"], fmt::format("lines[{}].name", i),
             fmt::format("a line called '{}' already exists", c.lines[i].name));
    }
    for (std::size_t j = 0; j < c.lines[i].axes.size(); ++j) {
      if (!axes.insert(c.lines[i].axes[j].name).second) {
        r.fail(node["axes"][j], fmt::format("lines[{}].axes[{}].name", i, j),
               fmt::format("an axis called '{}' already exists (names are unique across lines)",
                           c.lines[i].axes[j].name));
      }
    }
  }
}

ServeConfig read_root(const Reader& r, const YAML::Node& root) {
  if (!root.IsMap()) r.fail(root, "", "expected a map with lines: (and http:, mqtt:)");
  r.keys(root, "", {"lines", "http", "mqtt", "history", "sparkplug", "cycles"});
  ServeConfig c;
  c.source = r.source();
  const auto lines = root["lines"];
  if (!lines || !lines.IsSequence() || lines.size() == 0) {
    r.fail(lines ? lines : root, "lines", "expected a list of lines (at least one)");
  }
  for (std::size_t i = 0; i < lines.size(); ++i) {
    LineConfig l = read_line(r, lines[i], fmt::format("lines[{}]", i));
    if (l.name.empty()) l.name = fmt::format("line{}", i + 1);
    c.lines.push_back(std::move(l));
  }
  check_unique_names(r, root, c);
  read_cycles(r, root["cycles"], c);  // issue 34: machine cycles (serve/cycles/)
  c.http = read_http(r, root["http"]);
  c.mqtt = read_mqtt(r, root["mqtt"]);
  c.history = history::read_history(r, root["history"]);
  c.history_off = root["history"] && !c.history;  // issue 32: on by default, unless false
  c.sparkplug = read_sparkplug(r, root["sparkplug"]);
  if (c.sparkplug) {
    for (std::size_t i = 0; i < c.lines.size(); ++i) {
      for (std::size_t j = 0; j < c.lines[i].axes.size(); ++j) {
        if (const auto why = check_sparkplug_id(c.lines[i].axes[j].name)) {
          r.fail(root["lines"][i]["axes"][j], fmt::format("lines[{}].axes[{}].name", i, j),
                 "a Sparkplug device id: " + *why);
        }
      }
    }
  }
  return c;
}

}  // namespace

std::optional<std::string> check_sparkplug_id(const std::string& id) {
  if (id.empty()) return "empty";
  if (id.find_first_of("/+#") != std::string::npos) {
    return fmt::format("'{}' has a '/', '+' or '#' (Sparkplug ids are one topic level)", id);
  }
  return std::nullopt;
}

bool Endpoint::loopback() const {
  in_addr v4{};
  if (::inet_pton(AF_INET, address.c_str(), &v4) == 1) return (ntohl(v4.s_addr) >> 24) == 127;
  return address == "::1" || address == "localhost";
}

std::string Endpoint::text() const {
  return address.find(':') != std::string::npos ? fmt::format("[{}]:{}", address, port)
                                                : fmt::format("{}:{}", address, port);
}

BrokerUrl parse_broker_url(const std::string& text) {
  BrokerUrl url;
  std::string_view rest = text;
  if (rest.starts_with("mqtts://")) {
    url.tls = true;
    url.port = 8883;
    rest.remove_prefix(8);
  } else if (rest.starts_with("mqtt://")) {
    rest.remove_prefix(7);
  } else {
    throw std::invalid_argument(
        fmt::format("'{}': expected mqtt://host[:port] or mqtts://host[:port]", text));
  }
  if (rest.ends_with("/")) rest.remove_suffix(1);
  std::string_view port;
  if (rest.starts_with("[")) {  // [IPv6]:port
    const auto close = rest.find(']');
    if (close == std::string_view::npos) {
      throw std::invalid_argument(fmt::format("'{}': an IPv6 address needs its ']'", text));
    }
    url.host = std::string(rest.substr(1, close - 1));
    rest.remove_prefix(close + 1);
    if (!rest.empty() && !rest.starts_with(":")) {
      throw std::invalid_argument(fmt::format("'{}': expected :port after ']'", text));
    }
    if (!rest.empty()) port = rest.substr(1);
  } else {
    const auto colon = rest.rfind(':');
    url.host = std::string(rest.substr(0, colon));
    if (colon != std::string_view::npos) port = rest.substr(colon + 1);
  }
  if (url.host.empty() || url.host.find_first_of("/@?#") != std::string::npos) {
    throw std::invalid_argument(fmt::format("'{}': expected a host name or address", text));
  }
  if (!port.empty() || rest.ends_with(":")) {
    unsigned value = 0;
    const auto [end, ec] = std::from_chars(port.data(), port.data() + port.size(), value);
    if (ec != std::errc() || end != port.data() + port.size() || value < 1 || value > 65535) {
      throw std::invalid_argument(fmt::format("'{}': the port must be 1 to 65535", text));
    }
    url.port = static_cast<uint16_t>(value);
  }
  return url;
}

Duration LineConfig::cache_max_age() const {
  if (cache_max_age_ms) return to_duration(FractionalMilliseconds(*cache_max_age_ms));
  double slowest_hz = 0;
  for (const auto& a : axes) {
    if (a.telemetry_hz > 0 && (slowest_hz == 0 || a.telemetry_hz < slowest_hz))
      slowest_hz = a.telemetry_hz;
  }
  const double ms = slowest_hz > 0 ? 2000.0 / slowest_hz : 100.0;
  return to_duration(FractionalMilliseconds(std::max(ms, 100.0)));
}

std::optional<ServeConfig::Found> ServeConfig::find_axis(std::string_view name) const {
  for (const auto& l : lines) {
    for (const auto& a : l.axes) {
      if (a.name == name) return Found{&l, &a};
    }
  }
  return std::nullopt;
}

ServeConfig parse_config(const std::string& text, const std::string& source) {
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::ParserException& e) {
    throw ConfigError(fmt::format("{}:{}: not valid YAML: {}", source, e.mark.line + 1, e.msg));
  }
  return read_root(Reader(source), root);
}

ServeConfig load_config(const std::filesystem::path& file) {
  YAML::Node root;
  try {
    root = YAML::LoadFile(file.string());
  } catch (const YAML::BadFile&) {
    throw ConfigError(fmt::format("cannot read the config file {}", file.string()));
  } catch (const YAML::ParserException& e) {
    throw ConfigError(
        fmt::format("{}:{}: not valid YAML: {}", file.string(), e.mark.line + 1, e.msg));
  }
  return read_root(Reader(file.string()), root);
}

}  // namespace lec6::serve
