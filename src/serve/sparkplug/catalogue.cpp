#include "sparkplug/catalogue.hpp"

#include <fmt/format.h>

#include "lec6/version.hpp"

namespace lec6::serve::sparkplug {
namespace {

using nlohmann::json;
using T = DataType;

// A telemetry metric: its name, type and where telemetry_json() has it.
struct Telemetry {
  const char* name;
  DataType type;
  const char* pointer;
};

constexpr Telemetry kTelemetry[] = {
    {"Position mm", T::Double, "/position_mm"},
    {"Speed mm/s", T::Int32, "/speed_mm_s"},
    {"Thrust %", T::Int32, "/thrust_pct"},
    {"Target mm", T::Double, "/target_mm"},
    {"Step", T::Int32, "/step"},
    {"Flags/BUSY", T::Boolean, "/flags/busy"},
    {"Flags/SVRE", T::Boolean, "/flags/svre"},
    {"Flags/SETON", T::Boolean, "/flags/seton"},
    {"Flags/INP", T::Boolean, "/flags/inp"},
    {"Flags/AREA", T::Boolean, "/flags/area"},
    {"Flags/WAREA", T::Boolean, "/flags/warea"},
    {"Flags/ESTOP", T::Boolean, "/flags/estop"},
    {"Flags/ALARM", T::Boolean, "/flags/alarm"},
    {"Flags/OUT", T::Boolean, "/flags/out"},
    {"Inputs/IN", T::Int32, "/inputs/in"},
    {"Inputs/HOLD", T::Boolean, "/inputs/hold"},
    {"Inputs/SVON", T::Boolean, "/inputs/svon"},
    {"Inputs/DRIVE", T::Boolean, "/inputs/drive"},
    {"Inputs/RESET", T::Boolean, "/inputs/reset"},
    {"Inputs/SETUP", T::Boolean, "/inputs/setup"},
    {"Inputs/JOG-", T::Boolean, "/inputs/jog_minus"},
    {"Inputs/JOG+", T::Boolean, "/inputs/jog_plus"},
    {"Inputs/Serial Mode", T::Boolean, "/inputs/serial_mode"},
    {"Health/Error Rate", T::Double, "/error_rate"},
};

Value from_json(const json& j, DataType t) {
  if (j.is_null()) return {};
  switch (t) {
    case T::Boolean:
      return j.is_boolean() ? Value{j.get<bool>()} : Value{};
    case T::Double:
      return j.is_number() ? Value{j.get<double>()} : Value{};
    case T::String:
      return j.is_string() ? Value{j.get<std::string>()} : Value{j.dump()};
    default:
      return j.is_number() ? Value{static_cast<int64_t>(j.get<double>())} : Value{};
  }
}

}  // namespace

std::vector<MetricDef> node_metrics(const std::vector<LineConfig>& lines) {
  std::vector<MetricDef> m{{"Properties/Version", T::String, false}};
  for (const LineConfig& l : lines) {
    const std::string p = "Lines/" + l.name + "/";
    m.push_back({p + "State", T::String, false});
    m.push_back({p + "Transactions", T::Int64, false});
    m.push_back({p + "Timeouts", T::Int64, false});
    m.push_back({p + "CRC Errors", T::Int64, false});
    m.push_back({p + "Utilisation", T::Double, false});
  }
  return m;
}

std::vector<Value> node_values(const std::vector<LineNow>& lines) {
  std::vector<Value> v{std::string(kVersion)};
  for (const LineNow& l : lines) {
    uint64_t timeouts = 0, crc = 0;
    for (const auto& [id, d] : l.stats.devices) {
      timeouts += d.timeouts;
      crc += d.crc_errors;
    }
    v.emplace_back(l.state);
    v.emplace_back(static_cast<int64_t>(l.stats.transactions));
    v.emplace_back(static_cast<int64_t>(timeouts));
    v.emplace_back(static_cast<int64_t>(crc));
    // Rounded to the percent: the line's load is news, its jitter is not.
    v.emplace_back(std::round(l.stats.utilisation * 100.0) / 100.0);
  }
  return v;
}

std::vector<MetricDef> axis_metrics(bool history) {
  std::vector<MetricDef> m;
  for (const Telemetry& t : kTelemetry) m.push_back({t.name, t.type, false});
  m.push_back({"Alarms/Code", T::Int32, false});
  m.push_back({"Alarms/Meaning", T::String, false});
  m.push_back({"Alarms/Active", T::String, false});
  m.push_back({"Operation/Running", T::String, false});
  m.push_back({"Operation/Last Result", T::String, false});
  if (history) {
    m.push_back({"History/Odometer m", T::Double, false});
    m.push_back({"History/Health", T::String, false});
  }
  m.push_back({"Command/Outcome", T::String, false});
  m.push_back({"Command/Message", T::String, false});
  m.push_back({"Command/Status", T::Int32, false});
  m.push_back({"Command/Count", T::Int64, false});
  // The last stop's own result: a stop followed at once by another DCMD
  // still says whether the axis stopped.
  m.push_back({"Command/Stop Outcome", T::String, false});
  m.push_back({"Command/Stop Message", T::String, false});
  for (MetricDef& c : command_metrics()) m.push_back(std::move(c));
  return m;
}

std::vector<Value> axis_values(const AxisNow& now, bool history) {
  // Parsed once: every axis is sampled at telemetry_hz.
  static const std::vector<json::json_pointer> pointers = [] {
    std::vector<json::json_pointer> p;
    for (const Telemetry& t : kTelemetry) p.emplace_back(t.pointer);
    return p;
  }();
  std::vector<Value> v;
  v.reserve(64);
  for (std::size_t i = 0; i < pointers.size(); ++i) {
    const json* at = now.telemetry.contains(pointers[i]) ? &now.telemetry.at(pointers[i]) : nullptr;
    v.push_back(at ? from_json(*at, kTelemetry[i].type) : Value{});
  }
  // Alarms with their meanings: the first one's code and meaning, and all of them.
  const json alarms = now.telemetry.value("alarms", json::array());
  std::string active;
  for (const json& a : alarms) {
    active += fmt::format("{}{}: {}", active.empty() ? "" : "; ", a.value("code", 0),
                          a.value("meaning", std::string()));
  }
  const bool any = !alarms.empty();
  v.emplace_back(any ? int64_t{alarms[0].value("code", 0)} : int64_t{0});
  v.emplace_back(any ? alarms[0].value("meaning", std::string()) : std::string());
  v.emplace_back(active);
  v.emplace_back(now.running);
  v.emplace_back(now.last ? now.last->dump() : std::string());
  if (history) {
    Value odometer;
    if (now.health && now.health->contains("odometer")) {
      const json& o = (*now.health)["odometer"];
      if (o.is_object() && o.contains("distance_m"))
        odometer = from_json(o["distance_m"], T::Double);
    }
    v.push_back(odometer);
    v.emplace_back(now.health_text ? *now.health_text
                   : now.health    ? now.health->dump()
                                   : std::string());
  }
  static const CommandState kNone;
  const CommandState& c = now.command ? *now.command : kNone;
  v.emplace_back(c.outcome);
  v.emplace_back(c.message);
  v.emplace_back(c.status);
  v.emplace_back(c.count);
  v.emplace_back(c.stop_outcome);
  v.emplace_back(c.stop_message);
  // The writable metrics: actions read back false (they are momentary), the
  // move settings as last written (null until then).
  auto opt = [](const auto& o) { return o ? Value{*o} : Value{}; };
  for (int i = 0; i < 6; ++i) v.emplace_back(false);  // Stop .. Home
  v.emplace_back();                                   // Run Step
  v.push_back(opt(c.move.position_mm));
  v.push_back(opt(c.move.speed_mm_s));
  v.push_back(opt(c.move.accel_mm_s2));
  v.push_back(opt(c.move.decel_mm_s2));
  v.push_back(opt(c.move.force_pct));
  v.emplace_back(c.move.relative);
  v.emplace_back(false);
  return v;
}

}  // namespace lec6::serve::sparkplug
