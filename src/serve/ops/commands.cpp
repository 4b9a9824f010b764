#include "ops/commands.hpp"

#include <fmt/format.h>

#include <array>
#include <cmath>
#include <set>

namespace lec6::serve {
namespace {

using nlohmann::json;

struct OpEntry {
  Op op;
  std::string_view name;
};
constexpr std::array<OpEntry, 12> kOps{{
    {Op::Serial, "serial"},
    {Op::Servo, "servo"},
    {Op::Home, "home"},
    {Op::Move, "move"},
    {Op::RunStep, "run-step"},
    {Op::Jog, "jog"},
    {Op::JogStop, "jog-stop"},
    {Op::Hold, "hold"},
    {Op::Stop, "stop"},
    {Op::Reset, "reset"},
    {Op::StepRead, "step-read"},
    {Op::StepWrite, "step-write"},
}};

// A mistake found while reading arguments: thrown inside this file only,
// returned as an Expected error.
struct Bad {
  CommandError error;
};
[[noreturn]] void bad(std::string field, std::string message) {
  throw Bad{{std::move(field), std::move(message)}};
}

class Args {
 public:
  explicit Args(const json& j) : j_(j) {
    if (!j_.is_null() && !j_.is_object()) bad("", "the arguments must be a JSON object");
  }
  bool has(const char* key) const { return j_.is_object() && j_.contains(key); }
  const json& at(const char* key) const {
    used_.insert(key);
    return j_.at(key);
  }
  // Every key must be one the op knows: a typo must not be silently ignored.
  void no_others(std::string_view op) const {
    if (!j_.is_object()) return;
    for (const auto& [key, value] : j_.items()) {
      if (!used_.contains(key) && key != "op" && key != "id" && key != "valid_for" &&
          key != "issued_at") {
        bad(key, fmt::format("{} has no argument '{}'", op, key));
      }
    }
  }
  void mark(const char* key) const { used_.insert(key); }

 private:
  const json& j_;
  mutable std::set<std::string> used_;
};

bool boolean(const Args& a, const char* key, std::optional<bool> fallback = std::nullopt) {
  if (!a.has(key)) {
    if (fallback) return *fallback;
    bad(key, fmt::format("{} is required (true or false)", key));
  }
  const json& v = a.at(key);
  if (!v.is_boolean()) bad(key, fmt::format("{} must be true or false", key));
  return v.get<bool>();
}

double number(const Args& a, const char* key, double lo, double hi, const char* unit) {
  const json& v = a.at(key);
  if (!v.is_number()) bad(key, fmt::format("{} must be a number ({})", key, unit));
  const double x = v.get<double>();
  if (!std::isfinite(x) || x < lo || x > hi) {
    bad(key, fmt::format("{}: {} is outside {} to {} {}", key, x, lo, hi, unit));
  }
  return x;
}

// A step field given in the manual's units: the field table's parser decides
// (one rule for the CLI, files and this API).
int64_t field(const Args& a, const char* key, lec::StepField f) {
  const json& v = a.at(key);
  std::string text;
  if (v.is_number()) {
    text = v.dump();
  } else if (v.is_string()) {
    text = v.get<std::string>();
  } else {
    bad(key, fmt::format("{} must be a number", key));
  }
  auto raw = lec::parse_field(f, text);
  if (!raw) bad(key, raw.error());
  return *raw;
}

unsigned step_number(const Args& a, const char* key) {
  const json& v = a.at(key);
  if (!v.is_number_integer() || v.get<int64_t>() < 0 || v.get<int64_t>() > 63) {
    bad(key, "step must be a whole number from 0 to 63");
  }
  return static_cast<unsigned>(v.get<int64_t>());
}

template <typename T>
std::optional<T> opt_field(const Args& a, const char* key, lec::StepField f) {
  if (!a.has(key)) return std::nullopt;
  return static_cast<T>(field(a, key, f));
}

Duration timeout_of(const Args& a, double fallback_s) {
  const double s = a.has("timeout_s") ? number(a, "timeout_s", 0.1, 3600, "s") : fallback_s;
  return to_duration(FractionalSeconds(s));
}

void parse_move(const Args& a, Command& c) {
  if (a.has("step")) {
    c.op = Op::RunStep;
    c.step = step_number(a, "step");
    c.timeout = timeout_of(a, 60);
    return;
  }
  if (!a.has("position_mm"))
    bad("position_mm", "a move needs position_mm (or step to run a stored step)");
  using F = lec::StepField;
  auto& m = c.move;
  m.position_001mm = static_cast<int32_t>(field(a, "position_mm", F::Position));
  m.relative = boolean(a, "relative", false);
  m.keep = boolean(a, "keep", false);
  m.speed_mm_s = opt_field<uint16_t>(a, "speed_mm_s", F::Speed);
  m.acceleration_mm_s2 = opt_field<uint16_t>(a, "accel_mm_s2", F::Acceleration);
  m.deceleration_mm_s2 = opt_field<uint16_t>(a, "decel_mm_s2", F::Deceleration);
  m.moving_force_pct = opt_field<uint16_t>(a, "moving_force_pct", F::MovingForce);
  m.in_position_001mm = opt_field<int32_t>(a, "in_position_mm", F::InPosition);
  m.area1_001mm = opt_field<int32_t>(a, "area1_mm", F::Area1);
  m.area2_001mm = opt_field<int32_t>(a, "area2_mm", F::Area2);
  if (m.area1_001mm.has_value() != m.area2_001mm.has_value()) {
    bad(m.area1_001mm ? "area2_mm" : "area1_mm", "give both area1_mm and area2_mm, or neither");
  }
  m.pushing_force_pct = opt_field<uint16_t>(a, "push_pct", F::PushingForce);
  m.trigger_level_pct = opt_field<uint16_t>(a, "trigger_pct", F::TriggerLevel);
  m.pushing_speed_mm_s = opt_field<uint16_t>(a, "push_speed_mm_s", F::PushingSpeed);
  if (!m.pushing_force_pct && (m.trigger_level_pct || m.pushing_speed_mm_s)) {
    bad(m.trigger_level_pct ? "trigger_pct" : "push_speed_mm_s",
        "trigger_pct and push_speed_mm_s belong to a pushing move: give push_pct too");
  }
  c.timeout = timeout_of(a, 60);
}

void parse_jog(const Args& a, Command& c) {
  if (!a.has("direction")) bad("direction", "jog needs direction: \"+\" or \"-\"");
  const json& d = a.at("direction");
  if (!d.is_string() || (d != "+" && d != "-"))
    bad("direction", "direction must be \"+\" or \"-\"");
  c.jog_plus = d == "+";
  if (a.has("lease_ms") == a.has("duration_ms")) {
    bad("lease_ms", "give lease_ms (hold to run, renewed by repeating jog) or duration_ms");
  }
  if (a.has("lease_ms"))
    c.jog_lease = to_duration(FractionalMilliseconds(number(a, "lease_ms", 50, 5000, "ms")));
  if (a.has("duration_ms"))
    c.jog_duration = to_duration(FractionalMilliseconds(number(a, "duration_ms", 1, 60000, "ms")));
}

void parse_step_write(const Args& a, const json& args, Command& c) {
  if (!a.has("step")) bad("step", "step-write needs step (0 to 63)");
  c.step = step_number(a, "step");
  for (const auto& [key, value] : args.items()) {
    if (key == "step" || key == "op" || key == "id" || key == "valid_for" || key == "issued_at")
      continue;
    const lec::StepFieldInfo* info = lec::find_step_field(key);
    if (!info) bad(key, fmt::format("'{}' is not a step field (speed_mm_s, position_mm, …)", key));
    a.mark(key.c_str());
    if (info->field == lec::StepField::MovementMode) {
      auto raw = lec::parse_field(info->field,
                                  value.is_string() ? value.get<std::string>() : value.dump());
      if (!raw) bad(key, raw.error());
      c.fields[info->field] = *raw;
      continue;
    }
    c.fields[info->field] = field(a, key.c_str(), info->field);
  }
  if (c.fields.empty()) bad("", "step-write needs at least one field to change");
}

void parse_args(Op op, const json& args, Command& c) {
  const Args a(args);
  c.op = op;
  switch (op) {
    case Op::Serial:
    case Op::Servo:
    case Op::Hold:
      c.on = boolean(a, "on");
      break;
    case Op::Home:
      c.timeout = timeout_of(a, 60);
      break;
    case Op::Move:
      parse_move(a, c);
      break;
    case Op::RunStep:
      if (!a.has("step")) bad("step", "run-step needs step (0 to 63)");
      c.step = step_number(a, "step");
      c.timeout = timeout_of(a, 60);
      break;
    case Op::Jog:
      parse_jog(a, c);
      break;
    case Op::StepRead:
      if (a.has("step")) c.step = step_number(a, "step");
      break;
    case Op::StepWrite:
      parse_step_write(a, args, c);
      break;
    case Op::JogStop:
    case Op::Stop:
    case Op::Reset:
      break;
  }
  a.no_others(op_name(op));
}

}  // namespace

std::string_view op_name(Op op) noexcept {
  for (const auto& e : kOps) {
    if (e.op == op) return e.name;
  }
  return "?";
}

bool stops_motion(const Command& cmd) noexcept {
  return cmd.op == Op::Stop || cmd.op == Op::Reset || (cmd.op == Op::Hold && cmd.on);
}

bool is_motion(Op op) noexcept {
  return op == Op::Home || op == Op::Move || op == Op::RunStep || op == Op::Jog;
}

Expected<Command, CommandError> parse_command(std::string_view op, const nlohmann::json& args) {
  const OpEntry* entry = nullptr;
  for (const auto& e : kOps) {
    if (e.name == op) entry = &e;
  }
  if (!entry) {
    std::string known;
    for (const auto& e : kOps) known += (known.empty() ? "" : ", ") + std::string(e.name);
    return unexpected(CommandError{"op", fmt::format("unknown op '{}' (known: {})", op, known)});
  }
  Command c;
  try {
    parse_args(entry->op, args, c);
  } catch (const Bad& b) {
    return unexpected(b.error);
  }
  return c;
}

}  // namespace lec6::serve
