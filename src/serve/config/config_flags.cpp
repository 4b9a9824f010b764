// The config of `lec serve --port P --ids 1-4`, and the small parsers both
// forms share.

#include <fmt/format.h>

#include <charconv>
#include <set>

#include "lec6/serve/config.hpp"
#include "lec6/transport/port_spec.hpp"
#include "lec6/twin/field_profile.hpp"

namespace lec6::serve {
namespace {

int number(std::string_view text, std::string_view what) {
  int v = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
  if (ec != std::errc() || end != text.data() + text.size()) {
    throw ConfigError(fmt::format("'{}' is not a number ({})", text, what));
  }
  return v;
}

std::optional<ListenerConfig> listener(const std::string& text) {
  if (text.empty()) return std::nullopt;
  return ListenerConfig{parse_endpoint(text), false};
}

}  // namespace

std::vector<uint8_t> parse_ids(const std::string& text) {
  std::set<int> ids;
  std::string_view rest = text;
  while (!rest.empty()) {
    const auto comma = rest.find(',');
    const std::string_view part = rest.substr(0, comma);
    rest = comma == std::string_view::npos ? std::string_view{} : rest.substr(comma + 1);
    const auto dash = part.find('-');
    const int lo = number(part.substr(0, dash), "controller ID");
    const int hi =
        dash == std::string_view::npos ? lo : number(part.substr(dash + 1), "controller ID");
    if (lo < 1 || hi > 255 || lo > hi) {
      throw ConfigError(fmt::format(
          "IDs '{}': controller IDs are 1 to 255 (digest §2), ranges written low-high", part));
    }
    for (int i = lo; i <= hi; ++i) ids.insert(i);
  }
  if (ids.empty()) throw ConfigError("no controller IDs given: e.g. --ids 1-4");
  return {ids.begin(), ids.end()};
}

Endpoint parse_endpoint(const std::string& text) {
  Endpoint e;
  std::string_view port;
  if (text.starts_with('[')) {
    const auto close = text.find(']');
    if (close == std::string::npos || close + 1 >= text.size() || text[close + 1] != ':') {
      throw ConfigError(fmt::format("'{}': expected [address]:port", text));
    }
    e.address = text.substr(1, close - 1);
    port = std::string_view(text).substr(close + 2);
  } else {
    const auto colon = text.rfind(':');
    if (colon == std::string::npos) {
      throw ConfigError(fmt::format("'{}': expected address:port, e.g. 127.0.0.1:1502", text));
    }
    e.address = colon == 0 ? "127.0.0.1" : text.substr(0, colon);
    port = std::string_view(text).substr(colon + 1);
  }
  const int p = number(port, "TCP port");
  if (p < 0 || p > 65535) throw ConfigError(fmt::format("TCP port {} is outside 0 to 65535", p));
  e.port = static_cast<uint16_t>(p);
  return e;
}

ServeConfig config_from_flags(const FlagConfig& f) {
  if (f.port.empty()) {
    throw ConfigError("no line: give --config FILE, or --port /dev/ttyUSB0 (or sim) and --ids");
  }
  ServeConfig c;
  c.source = "command line";
  LineConfig line;
  line.name = "line1";
  line.port = f.port;
  if (transport::parse_port_spec(f.port).kind == transport::PortKind::Tcp) {
    throw ConfigError(fmt::format(
        "--port {}: lec serve drives a line in Modbus RTU (a serial port, sim or rtu+tcp://); "
        "Modbus TCP is what it serves",
        f.port));
  }
  line.baud = f.baud;
  line.sim.fast = f.fast_sim;
  line.sim.profile = f.sim_profile;
  try {
    line.sim.actuator = twin::named_profile(f.sim_profile).actuator;
  } catch (const twin::ProfileError& e) {
    throw ConfigError(
        fmt::format("--sim-profile: default, ideal or a field profile file: {}", e.what()));
  }
  line.sim.stroke_max_mm = line.sim.actuator.stroke_max_mm;
  line.sim.initial_position_mm = line.sim.actuator.initial_position_mm;
  line.sim.workpiece_mm = line.sim.actuator.workpiece_mm;
  line.sim.wear_pct_per_m = line.sim.actuator.wear_pct_per_m;
  for (uint8_t id : parse_ids(f.ids)) {
    AxisConfig a{id, fmt::format("axis{}", id), f.telemetry_hz, std::nullopt};
    a.alarm_polarity = f.alarm_polarity;
    line.axes.push_back(std::move(a));
  }
  line.modbus_tcp = listener(f.modbus_tcp);
  line.rtu_tcp = listener(f.rtu_tcp);
  c.lines.push_back(std::move(line));
  if (!f.http.empty()) {
    HttpConfig h;
    h.listener = *listener(f.http);
    h.token = f.token;
    if (!h.listener.listen.loopback() && h.token.empty()) {
      throw ConfigError(fmt::format(
          "--http {} is reachable from other machines: give --token (writes need it)", f.http));
    }
    c.http = h;
  }
  if (!f.state_dir.empty()) {  // issue 26: the move history
    HistoryConfig h;
    h.state_dir = f.state_dir;
    c.history = h;
  }
  return c;
}

}  // namespace lec6::serve
