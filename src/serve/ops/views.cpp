#include "ops/views.hpp"

#include <fmt/format.h>

#include "lec6/client/actuator.hpp"
#include "lec6/lec/alarms.hpp"
#include "lec6/lec/step_table.hpp"

namespace lec6::serve {
namespace {

double mm(int64_t v001) {
  return static_cast<double>(v001) / 100.0;
}

nlohmann::json flags_json(const lec::StatusFlags& f) {
  return {{"busy", f.busy()},   {"svre", f.svre()},   {"seton", f.seton()},
          {"inp", f.inp()},     {"area", f.area()},   {"warea", f.warea()},
          {"estop", f.estop()}, {"alarm", f.alarm()}, {"out", f.out()}};
}

nlohmann::json inputs_json(const lec::ControlFlags& c) {
  using lec::Coil;
  return {{"in", c.selected_step()},
          {"hold", c.test(Coil::HOLD)},
          {"svon", c.test(Coil::SVON)},
          {"drive", c.test(Coil::DRIVE)},
          {"reset", c.test(Coil::RESET)},
          {"setup", c.test(Coil::SETUP)},
          {"jog_minus", c.test(Coil::JOG_MINUS)},
          {"jog_plus", c.test(Coil::JOG_PLUS)},
          {"serial_mode", c.serial_mode}};
}

nlohmann::json alarm_list(const std::vector<uint8_t>& codes) {
  auto out = nlohmann::json::array();
  for (uint8_t c : codes) {
    out.push_back({{"code", c},
                   {"meaning", std::string(lec::alarm_meaning(c))},
                   {"resettable", lec::alarm_resettable(c)}});
  }
  return out;
}

// Health as the dashboard's cards show it: how old the last answer is, and
// the share of exchanges that failed.
void health_into(nlohmann::json& j, const AxisRef& axis) {
  const auto h = axis.line->health(axis.id);
  j["online"] = !h.offline && !axis.line->is_down();
  if (h.offline) {
    j["offline_reason"] = fmt::format(
        "not answering: backed off after {} failed exchanges (last: {}); probed again "
        "every {:.1f} s",
        h.consecutive_failures, h.last_error, axis.line_config->probe_interval_ms / 1000.0);
  }
  const DeviceCounters c = axis.line->device_counters(axis.id);
  double error_rate = 0;
  if (c.transactions > 0) {
    error_rate = static_cast<double>(c.timeouts + c.crc_errors + c.framing_errors) /
                 static_cast<double>(c.transactions);
  }
  j["error_rate"] = error_rate;
}

// How old each value shown is: per block read (flags, state, inputs), and
// `age_ms`, the oldest of flags and state (what position and flags say is at
// least that old). Never the newest answer's age: after an outage the flags
// may be fresh while the position is the one from before it.
void ages_into(nlohmann::json& j, const AxisRef& axis, const AxisSnapshot& s) {
  const TimePoint now = axis.line->clock().now();
  const auto age = [&](bool has, TimePoint at) -> std::optional<double> {
    if (!has) return std::nullopt;
    return to_ms(now - at);
  };
  const auto as_json = [](std::optional<double> v) {
    return v ? nlohmann::json(*v) : nlohmann::json(nullptr);
  };
  const auto flags = age(s.flags.has_value(), s.flags_at);
  const auto state = age(s.state.has_value(), s.state_at);
  j["ages_ms"] = {{"flags", as_json(flags)},
                  {"state", as_json(state)},
                  {"inputs", as_json(age(s.controls.has_value(), s.controls_at))}};
  std::optional<double> oldest = flags;
  if (state && (!oldest || *state > *oldest)) oldest = state;
  j["age_ms"] = as_json(oldest);
}

void state_into(nlohmann::json& j, const AxisSnapshot& s) {
  if (s.state) {
    j["position_mm"] = mm(s.state->position_001mm);
    j["speed_mm_s"] = s.state->speed_mm_s;
    j["thrust_pct"] = s.state->thrust_pct;
    j["target_mm"] = mm(s.state->target_001mm);
    j["step"] = s.state->step_no;
  }
  if (s.flags) j["flags"] = flags_json(*s.flags);
  if (s.controls) j["inputs"] = inputs_json(*s.controls);
  std::vector<uint8_t> active;
  if (s.flags && s.flags->alarm() && s.alarms) active = s.alarms->groups[0].present();
  j["alarms"] = alarm_list(active);
}

}  // namespace

nlohmann::json telemetry_json(const AxisRef& axis, const AxisSnapshot& snapshot) {
  nlohmann::json j{{"name", axis.name}, {"line", axis.line_config->name}, {"id", axis.id}};
  state_into(j, snapshot);
  health_into(j, axis);
  ages_into(j, axis, snapshot);
  return j;
}

nlohmann::json axis_json(const AxisRef& axis, const Operations* ops) {
  const AxisSnapshot s = axis.line->snapshot(axis.id);
  nlohmann::json j = telemetry_json(axis, s);
  auto history = nlohmann::json::array();
  if (s.alarms) {
    for (std::size_t g = 0; g < s.alarms->groups.size(); ++g) {
      const auto codes = s.alarms->groups[g].present();
      if (!codes.empty()) history.push_back({{"group", g}, {"alarms", alarm_list(codes)}});
    }
  }
  j["alarm_history"] = history;
  // How X4F is read for this axis (AxisConfig::alarm_polarity).
  j["alarm_polarity"] = std::string(lec::to_string(axis.config->alarm_polarity));
  j["telemetry_hz"] = axis.config->telemetry_hz;
  if (ops) {
    const auto running = ops->running(axis);
    j["operation"] =
        running ? nlohmann::json{{"op", running->op},
                                 {"source", running->source},
                                 {"running_s", running->running_s},
                                 {"unsettled", running->unsettled},
                                 {"waiting_for", running->waiting_for.empty()
                                                     ? nlohmann::json(nullptr)
                                                     : nlohmann::json(running->waiting_for)}}
                : nlohmann::json(nullptr);
    const auto last = ops->last_result(axis.name);
    j["last_result"] = last ? *last : nlohmann::json(nullptr);
  }
  return j;
}

nlohmann::json stats_json(const LineStatsSnapshot& s, const LineConfig& config) {
  nlohmann::json priorities = nlohmann::json::object();
  for (std::size_t p = 0; p < kPriorities; ++p) {
    const auto& l = s.latency[p];
    std::vector<uint64_t> buckets(l.buckets.begin(), l.buckets.end());
    priorities[std::string(priority_name(static_cast<Priority>(p)))] = {
        {"queue_depth", s.queue_depth[p]},
        {"count", l.count},
        {"p50_ms", l.p50_ms},
        {"p99_ms", l.p99_ms},
        {"wait_p50_ms", l.wait_p50_ms},
        {"wait_p99_ms", l.wait_p99_ms},
        {"wait_max_ms", l.wait_max_ms},
        {"wait_count", l.wait_count},
        {"buckets_le_ms", kLatencyBucketsMs},
        {"buckets", buckets}};
    if (!l.recent_waits_ms.empty()) {
      priorities[std::string(priority_name(static_cast<Priority>(p)))]["recent_waits_ms"] =
          l.recent_waits_ms;
    }
  }
  nlohmann::json devices = nlohmann::json::array();
  for (const auto& [id, d] : s.devices) {
    std::string name;
    for (const auto& a : config.axes) {
      if (a.id == id) name = a.name;
    }
    devices.push_back({{"id", id},
                       {"axis", name},
                       {"transactions", d.transactions},
                       {"answers", d.answers},
                       {"timeouts", d.timeouts},
                       {"crc_errors", d.crc_errors},
                       {"framing_errors", d.framing_errors},
                       {"exceptions", d.exceptions},
                       {"superseded", d.superseded}});
  }
  return {{"transactions_per_s", s.transactions_per_s},
          {"utilisation", s.utilisation},
          {"busy", s.busy},
          {"transactions", s.transactions},
          {"cache_hits", s.cache_hits},
          {"priorities", priorities},
          {"devices", devices}};
}

nlohmann::json step_fields_json() {
  const lec::StepData defaults = client::default_direct_data();
  auto fields = nlohmann::json::array();
  for (const auto& i : lec::step_fields()) {
    // Lengths travel in 0.01 mm and are shown in mm with 2 decimals.
    const auto shown = [&](int64_t raw) {
      return i.is_length ? nlohmann::json(mm(raw)) : nlohmann::json(raw);
    };
    nlohmann::json f{{"name", i.name},
                     {"csv_column", i.csv_column},
                     {"label", i.label},
                     {"unit", i.unit},
                     {"min", shown(i.min)},
                     {"max", shown(i.max)},
                     {"is_length", i.is_length},
                     {"decimals", i.is_length ? 2 : 0},
                     {"default", shown(lec::get_field(defaults, i.field))}};
    if (i.field == lec::StepField::MovementMode) {
      f["choices"] = {{{"value", 1}, {"text", "abs"}}, {{"value", 2}, {"text", "inc"}}};
    }
    fields.push_back(f);
  }
  // lec::validate()'s rule between fields (manual §10.4), for pages to show as
  // the user types; the daemon checks it again on every write.
  const auto& trigger = lec::field_info(lec::StepField::TriggerLevel);
  const auto& push = lec::field_info(lec::StepField::PushingForce);
  auto rules = nlohmann::json::array();
  rules.push_back({{"field", trigger.csv_column},
                   {"at_most", push.csv_column},
                   {"when_positive", push.csv_column},
                   {"message", "trigger level exceeds pushing force"}});
  return {{"fields", fields}, {"rules", rules}, {"steps", lec::StepTable::kSteps}};
}

nlohmann::json line_json(const LineConfig& c, const Line& line) {
  nlohmann::json axes = nlohmann::json::array();
  for (const auto& a : c.axes) axes.push_back({{"name", a.name}, {"id", a.id}});
  nlohmann::json j{{"name", c.name},
                   {"port", c.port},
                   {"describe", line.describe()},
                   {"baud", c.baud},
                   {"silent_interval", c.silent_interval},
                   {"delay_ms", c.delay_ms},
                   {"sim", c.port == "sim"},
                   {"up", !line.is_down()},
                   {"axes", axes},
                   {"stats", stats_json(line.stats(), c)}};
  if (line.is_down()) j["down_reason"] = line.down_reason();
  return j;
}

}  // namespace lec6::serve
