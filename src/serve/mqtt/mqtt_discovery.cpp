#include "mqtt/mqtt_discovery.hpp"

#include <fmt/format.h>

namespace lec6::serve {
namespace {

using nlohmann::json;

// Discovery ids allow [a-zA-Z0-9_-]; the prefix may hold '/'.
std::string node_id(const MqttTopics& t, const std::string& line, const std::string& axis) {
  std::string id = fmt::format("{}_{}_{}", t.prefix(), line, axis);
  for (char& c : id) {
    const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
                    c == '_' || c == '-';
    if (!ok) c = '_';
  }
  return id;
}

struct Sensor {
  const char* key;  // the state's JSON key, and the object id
  const char* name;
  const char* unit;
  const char* device_class;  // "" for none
};
constexpr Sensor kSensors[] = {
    {"position_mm", "Position", "mm", "distance"},
    {"speed_mm_s", "Speed", "mm/s", "speed"},
    {"thrust_pct", "Thrust", "%", ""},
};

struct Flag {
  const char* key;  // in the state's "flags"
  const char* name;
  const char* device_class;
};
constexpr Flag kFlags[] = {
    {"busy", "Busy", "running"},        {"inp", "In position (INP)", ""},
    {"svre", "Servo ready (SVRE)", ""}, {"seton", "Origin set (SETON)", ""},
    {"alarm", "Alarm", "problem"},      {"estop", "Emergency stop (ESTOP)", "safety"},
};

struct Button {
  const char* op;
  const char* name;
};
constexpr Button kButtons[] = {{"home", "Home"}, {"stop", "Stop"}};

}  // namespace

std::vector<Publication> home_assistant_discovery(const MqttTopics& t, const std::string& line,
                                                  const std::string& axis, int controller_id) {
  const std::string node = node_id(t, line, axis);
  const json device{{"identifiers", json::array({node})},
                    {"name", axis},
                    {"manufacturer", "SMC"},
                    {"model", fmt::format("LEC6 controller {} on line {}", controller_id, line)}};
  const json availability =
      json::array({{{"topic", t.status()}}, {{"topic", t.availability(line, axis)}}});
  auto entity = [&](const char* component, const std::string& object, const std::string& name) {
    json p{{"name", name},
           {"unique_id", node + "_" + object},
           {"object_id", node + "_" + object},
           {"device", device},
           {"availability", availability},
           {"availability_mode", "all"},
           {"origin", {{"name", "lec6"}}}};
    return Publication{
        fmt::format("{}/{}/{}/{}/config", kHomeAssistantPrefix, component, node, object), p};
  };
  std::vector<Publication> out;
  for (const Sensor& s : kSensors) {
    auto p = entity("sensor", s.key, s.name);
    p.payload["state_topic"] = t.state(line, axis);
    p.payload["value_template"] = fmt::format("{{{{ value_json.{} }}}}", s.key);
    p.payload["unit_of_measurement"] = s.unit;
    p.payload["state_class"] = "measurement";
    if (*s.device_class) p.payload["device_class"] = s.device_class;
    out.push_back(std::move(p));
  }
  for (const Flag& f : kFlags) {
    auto p = entity("binary_sensor", f.key, f.name);
    p.payload["state_topic"] = t.state(line, axis);
    p.payload["value_template"] =
        fmt::format("{{{{ 'ON' if value_json.flags.{} else 'OFF' }}}}", f.key);
    if (*f.device_class) p.payload["device_class"] = f.device_class;
    out.push_back(std::move(p));
  }
  for (const Button& b : kButtons) {
    auto p = entity("button", b.op, b.name);
    p.payload["command_topic"] = t.cmd(line, axis);
    // Each press needs its own id: a repeated id is answered, not run again.
    p.payload["command_template"] =
        fmt::format(R"({{"id": "ha-{}-{{{{ now().timestamp() }}}}", "op": "{}"}})", b.op, b.op);
    p.payload["qos"] = 1;
    out.push_back(std::move(p));
  }
  return out;
}

}  // namespace lec6::serve
