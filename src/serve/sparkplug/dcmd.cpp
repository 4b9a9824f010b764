#include "sparkplug/dcmd.hpp"

#include <fmt/format.h>

#include <cmath>

namespace lec6::serve::sparkplug {
namespace {

enum Index : std::size_t {
  kStop,
  kHold,
  kReset,
  kSerial,
  kServo,
  kHome,
  kRunStep,
  kPosition,
  kSpeed,
  kAccel,
  kDecel,
  kForce,
  kRelative,
  kExecute,
  kCount
};

bool as_bool(const Value& v) {
  return std::holds_alternative<bool>(v) && std::get<bool>(v);
}

double as_double(const Value& v) {
  if (const auto* d = std::get_if<double>(&v)) return *d;
  if (const auto* i = std::get_if<int64_t>(&v)) return static_cast<double>(*i);
  if (const auto* u = std::get_if<uint64_t>(&v)) return static_cast<double>(*u);
  return 0;
}

int64_t as_int(const Value& v) {
  if (const auto* i = std::get_if<int64_t>(&v)) return *i;
  if (const auto* u = std::get_if<uint64_t>(&v)) return static_cast<int64_t>(*u);
  return 0;
}

}  // namespace

std::vector<MetricDef> command_metrics() {
  using T = DataType;
  std::vector<MetricDef> m(kCount);
  m[kStop] = {"Command/Stop", T::Boolean, true};
  m[kHold] = {"Command/Hold", T::Boolean, true};
  m[kReset] = {"Command/Reset", T::Boolean, true};
  m[kSerial] = {"Command/Serial", T::Boolean, true};
  m[kServo] = {"Command/Servo", T::Boolean, true};
  m[kHome] = {"Command/Home", T::Boolean, true};
  m[kRunStep] = {"Command/Run Step", T::Int32, true};
  m[kPosition] = {"Command/Move/Position mm", T::Double, true};
  m[kSpeed] = {"Command/Move/Speed mm/s", T::Int32, true};
  m[kAccel] = {"Command/Move/Accel mm/s2", T::Int32, true};
  m[kDecel] = {"Command/Move/Decel mm/s2", T::Int32, true};
  m[kForce] = {"Command/Move/Force %", T::Int32, true};
  m[kRelative] = {"Command/Move/Relative", T::Boolean, true};
  m[kExecute] = {"Command/Move/Execute", T::Boolean, true};
  return m;
}

Expected<Plan, std::string> plan(const std::vector<Write>& writes, const MoveSettings& current) {
  const auto names = command_metrics();
  Plan p;
  p.move = current;
  // The one stop rule: a stop goes first and waits for nothing, not even the
  // checks of what else this DCMD holds.
  for (const Write& w : writes) {
    if (w.metric == kStop && as_bool(w.value)) {
      p.command = Command{};
      p.command->op = Op::Stop;
      if (writes.size() > 1) p.note = "only the stop ran: the rest of this DCMD was not applied";
      return p;
    }
  }
  std::vector<std::pair<std::string, nlohmann::json>> actions;  // op, arguments
  bool execute = false;
  bool settings = false;
  for (const Write& w : writes) {
    if (w.metric >= kPosition && w.metric <= kRelative) settings = true;
    const Value& v = w.value;
    switch (w.metric) {
      case kStop:
        break;  // false: nothing to do
      case kHold:
        actions.push_back({"hold", {{"on", as_bool(v)}}});
        break;
      case kSerial:
        actions.push_back({"serial", {{"on", as_bool(v)}}});
        break;
      case kServo:
        actions.push_back({"servo", {{"on", as_bool(v)}}});
        break;
      case kReset:
        if (as_bool(v)) actions.push_back({"reset", nlohmann::json::object()});
        break;
      case kHome:
        if (as_bool(v)) actions.push_back({"home", nlohmann::json::object()});
        break;
      case kRunStep:
        actions.push_back({"run-step", {{"step", as_int(v)}}});
        break;
      case kPosition: {
        p.written |= 1;
        const double mm = as_double(v);
        if (!std::isfinite(mm))
          return unexpected(std::string("Command/Move/Position mm is not a number"));
        p.move.position_mm = mm;
        break;
      }
      case kSpeed:
        p.written |= 2;
        p.move.speed_mm_s = as_int(v);
        break;
      case kAccel:
        p.written |= 4;
        p.move.accel_mm_s2 = as_int(v);
        break;
      case kDecel:
        p.written |= 8;
        p.move.decel_mm_s2 = as_int(v);
        break;
      case kForce:
        p.written |= 16;
        p.move.force_pct = as_int(v);
        break;
      case kRelative:
        p.written |= 32;
        p.move.relative = as_bool(v);
        break;
      case kExecute:
        if (as_bool(v)) execute = true;
        break;
      default:
        return unexpected(fmt::format("metric {} is not a command", w.metric));
    }
  }
  auto move_args = [&](double position_mm) {
    nlohmann::json a{{"position_mm", position_mm}, {"relative", p.move.relative}};
    if (p.move.speed_mm_s) a["speed_mm_s"] = *p.move.speed_mm_s;
    if (p.move.accel_mm_s2) a["accel_mm_s2"] = *p.move.accel_mm_s2;
    if (p.move.decel_mm_s2) a["decel_mm_s2"] = *p.move.decel_mm_s2;
    if (p.move.force_pct) a["moving_force_pct"] = *p.move.force_pct;
    return a;
  };
  if (execute) {
    if (!p.move.position_mm) {
      return unexpected(std::string(
          "Command/Move/Execute needs Command/Move/Position mm (in this DCMD or an earlier one)"));
    }
    actions.push_back({"move", move_args(*p.move.position_mm)});
  } else if (settings) {
    // Settings alone are kept only when a move with them would pass the checks.
    auto c = parse_command("move", move_args(p.move.position_mm.value_or(0)));
    if (!c) return unexpected(c.error().message);
  }
  if (actions.size() > 1) {
    std::string list;
    for (const auto& a : actions) list += (list.empty() ? "" : ", ") + a.first;
    return unexpected(fmt::format("one action per DCMD, not {} ({})", actions.size(), list));
  }
  if (actions.empty()) return p;
  // The same checks as the HTTP API's and the MQTT bridge's.
  auto c = parse_command(actions[0].first, actions[0].second);
  if (!c) {
    const auto& e = c.error();
    return unexpected(e.message);
  }
  p.command = std::move(*c);
  return p;
}

namespace {

// Applies the fields of `from` that `written` names to `to`.
void apply(MoveSettings& to, const MoveSettings& from, uint8_t written) {
  if (written & 1) to.position_mm = from.position_mm;
  if (written & 2) to.speed_mm_s = from.speed_mm_s;
  if (written & 4) to.accel_mm_s2 = from.accel_mm_s2;
  if (written & 8) to.decel_mm_s2 = from.decel_mm_s2;
  if (written & 16) to.force_pct = from.force_pct;
  if (written & 32) to.relative = from.relative;
}

void recompute(CommandState& s) {
  s.move = s.kept;
  for (const auto& p : s.pending) apply(s.move, p.values, p.written);
}

}  // namespace

void record_settings(CommandState& s, int64_t count, const Plan& plan) {
  if (plan.written == 0) return;
  s.pending.push_back({count, plan.written, plan.move, false});
  recompute(s);
}

void settle_settings(CommandState& s, int64_t count, bool refused) {
  for (auto it = s.pending.begin(); it != s.pending.end(); ++it) {
    if (it->count != count) continue;
    if (refused) {
      s.pending.erase(it);
    } else {
      it->kept = true;
    }
    break;
  }
  while (!s.pending.empty() && s.pending.front().kept) {
    apply(s.kept, s.pending.front().values, s.pending.front().written);
    s.pending.pop_front();
  }
  recompute(s);
}

}  // namespace lec6::serve::sparkplug
