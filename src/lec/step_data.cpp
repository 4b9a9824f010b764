#include "lec6/lec/step_data.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cctype>

#include "lec6/lec/units.hpp"
#include "lec6/lec/words.hpp"

namespace lec6::lec {
namespace {

constexpr int64_t kI32 = 2147483647;

// clang-format off
constexpr std::array<StepFieldInfo, kStepFieldCount> kFields{{
  {StepField::MovementMode, "mode",         "movement_mode", "mode",               "Movement mode",   "",      0x0, 1, false, 1, 2},
  {StepField::Speed,        "speed",        "speed",         "speed_mm_s",         "Speed",           "mm/s",  0x1, 1, false, 1, 65535},
  {StepField::Position,     "position",     "position",      "position_mm",        "Position",        "mm",    0x2, 2, true, -kI32, kI32},
  {StepField::Acceleration, "accel",        "acceleration",  "accel_mm_s2",        "Acceleration",    "mm/s²", 0x4, 1, false, 1, 65535},
  {StepField::Deceleration, "decel",        "deceleration",  "decel_mm_s2",        "Deceleration",    "mm/s²", 0x5, 1, false, 1, 65535},
  {StepField::PushingForce, "push",         "pushing_force", "pushing_force_pct",  "Pushing force",   "%",     0x6, 1, false, 0, 100},
  {StepField::TriggerLevel, "trigger",      "trigger_level", "trigger_level_pct",  "Trigger level",   "%",     0x7, 1, false, 0, 100},
  {StepField::PushingSpeed, "push-speed",   "pushing_speed", "pushing_speed_mm_s", "Pushing speed",   "mm/s",  0x8, 1, false, 1, 65535},
  {StepField::MovingForce,  "moving-force", "moving_force",  "moving_force_pct",   "Moving force",    "%",     0x9, 1, false, 0, 300},
  {StepField::Area1,        "area1",        "area_output_end_1", "area1_mm",       "Area 1",          "mm",    0xA, 2, true, -kI32, kI32},
  {StepField::Area2,        "area2",        "area_output_end_2", "area2_mm",       "Area 2",          "mm",    0xC, 2, true, -kI32, kI32},
  {StepField::InPosition,   "in-position",  "in_position",   "in_position_mm",     "In position",     "mm",    0xE, 2, true, 0, kI32},
}};
// clang-format on
// In position from 0, not the manual's 1 (§10.2 prints 1…2147483647): field evidence,
// issue 24, docs/protocol-decisions.md "In position 0" and docs/twin-fidelity.md R-RANGE-INP.
// The other ranges are the manual's (ledger rows R-RANGE-*).

// Extra spellings people use for the same fields.
struct Alias {
  std::string_view name;
  StepField field;
};
constexpr std::array<Alias, 8> kAliases{{
    {"movement", StepField::MovementMode},
    {"acceleration_mm_s2", StepField::Acceleration},
    {"deceleration_mm_s2", StepField::Deceleration},
    {"pushing_force_pct", StepField::PushingForce},
    {"trigger_lv", StepField::TriggerLevel},
    {"area_1", StepField::Area1},
    {"area_2", StepField::Area2},
    {"inp", StepField::InPosition},
}};

std::string normalise_name(std::string_view s) {
  std::string out;
  out.reserve(s.size());
  for (char c : s)
    out.push_back(c == '-' ? '_' : static_cast<char>(std::tolower(static_cast<unsigned char>(c))));
  return out;
}

std::string range_text(const StepFieldInfo& i) {
  if (i.field == StepField::MovementMode) return "abs or inc";
  if (i.is_length) return fmt::format("{} to {} mm", format_mm(i.min), format_mm(i.max));
  return fmt::format("{} to {}{}{}", i.min, i.max, i.unit.empty() ? "" : " ", i.unit);
}

}  // namespace

std::array<uint16_t, StepData::kRegisters> StepData::to_registers() const noexcept {
  return {static_cast<uint16_t>(movement_mode),
          speed_mm_s,
          high_word(position_001mm),
          low_word(position_001mm),
          acceleration_mm_s2,
          deceleration_mm_s2,
          pushing_force_pct,
          trigger_level_pct,
          pushing_speed_mm_s,
          moving_force_pct,
          high_word(area1_001mm),
          low_word(area1_001mm),
          high_word(area2_001mm),
          low_word(area2_001mm),
          high_word(in_position_001mm),
          low_word(in_position_001mm)};
}

StepData StepData::from_registers(std::span<const uint16_t> regs) noexcept {
  std::array<uint16_t, kRegisters> r{};
  std::copy_n(regs.begin(), std::min(regs.size(), kRegisters), r.begin());
  StepData s;
  s.movement_mode = static_cast<MovementMode>(r[0]);
  s.speed_mm_s = r[1];
  s.position_001mm = join_words(r[2], r[3]);
  s.acceleration_mm_s2 = r[4];
  s.deceleration_mm_s2 = r[5];
  s.pushing_force_pct = r[6];
  s.trigger_level_pct = r[7];
  s.pushing_speed_mm_s = r[8];
  s.moving_force_pct = r[9];
  s.area1_001mm = join_words(r[10], r[11]);
  s.area2_001mm = join_words(r[12], r[13]);
  s.in_position_001mm = join_words(r[14], r[15]);
  return s;
}

std::span<const StepFieldInfo> step_fields() noexcept {
  return kFields;
}
const StepFieldInfo& field_info(StepField f) noexcept {
  return kFields[static_cast<std::size_t>(f)];
}

const StepFieldInfo* find_step_field(std::string_view name) noexcept {
  const std::string n = normalise_name(name);
  for (const auto& i : kFields) {
    if (n == normalise_name(i.name) || n == normalise_name(i.long_name) ||
        n == normalise_name(i.csv_column))
      return &i;
  }
  for (const auto& a : kAliases) {
    if (n == a.name) return &field_info(a.field);
  }
  return nullptr;
}

int64_t get_field(const StepData& s, StepField f) noexcept {
  const auto regs = s.to_registers();
  const auto& i = field_info(f);
  if (i.registers == 2) return join_words(regs[i.offset], regs[i.offset + 1]);
  return regs[i.offset];
}

void set_field(StepData& s, StepField f, int64_t raw) noexcept {
  auto regs = s.to_registers();
  const auto& i = field_info(f);
  if (i.registers == 2) {
    regs[i.offset] = high_word(static_cast<int32_t>(raw));
    regs[i.offset + 1] = low_word(static_cast<int32_t>(raw));
  } else {
    regs[i.offset] = static_cast<uint16_t>(raw);
  }
  s = StepData::from_registers(regs);
}

std::string format_field(StepField f, int64_t raw) {
  if (f == StepField::MovementMode) {
    switch (raw) {
      case 0:
        return "blank";
      case 1:
        return "abs";
      case 2:
        return "inc";
      default:
        return fmt::format("{}?", raw);
    }
  }
  if (field_info(f).is_length) return format_mm(raw);
  return fmt::format("{}", raw);
}

Expected<int64_t, std::string> parse_field(StepField f, std::string_view text) {
  const auto& i = field_info(f);
  if (f == StepField::MovementMode) {
    const std::string t = normalise_name(text);
    if (t == "abs" || t == "absolute" || t == "1") return int64_t{1};
    if (t == "inc" || t == "incremental" || t == "relative" || t == "2") return int64_t{2};
    return unexpected(fmt::format("{} '{}': expected abs or inc", i.name, text));
  }
  auto v = i.is_length ? parse_mm(text) : parse_integer(text);
  if (!v) return unexpected(fmt::format("{}: {}", i.name, v.error()));
  if (*v < i.min || *v > i.max) {
    return unexpected(fmt::format("{} {}{}{} is out of range: allowed {}", i.name, text,
                                  i.unit.empty() ? "" : " ", i.unit, range_text(i)));
  }
  return *v;
}

std::vector<ValidationIssue> validate(const StepData& s) {
  std::vector<ValidationIssue> issues;
  for (const auto& i : kFields) {
    const int64_t v = get_field(s, i.field);
    if (v < i.min || v > i.max) {
      const std::string shown = i.is_length ? format_mm(v) : fmt::format("{}", v);
      issues.push_back({i.field, fmt::format("{} {}{}{} is out of range ({})", i.name, shown,
                                             i.unit.empty() ? "" : " ", i.unit, range_text(i))});
    }
  }
  if (s.pushing_force_pct > 0 && s.pushing_force_pct <= 100 &&
      s.trigger_level_pct > s.pushing_force_pct) {
    issues.push_back(
        {StepField::TriggerLevel, fmt::format("trigger level {} % exceeds pushing force {} %",
                                              s.trigger_level_pct, s.pushing_force_pct)});
  }
  return issues;
}

std::vector<std::string> validation_messages(const StepData& s, std::optional<unsigned> step) {
  const std::string prefix =
      step ? fmt::format("step {}: ", *step) : std::string("direct operation: ");
  std::vector<std::string> out;
  for (const auto& issue : validate(s)) out.push_back(prefix + issue.message);
  return out;
}

std::string step_register_name(unsigned offset) {
  for (const auto& i : kFields) {
    if (offset == i.offset)
      return i.registers == 2 ? fmt::format("{} (high word)", i.name) : std::string(i.name);
    if (i.registers == 2 && offset == i.offset + 1u) return fmt::format("{} (low word)", i.name);
  }
  return fmt::format("offset {:X}", offset);
}

}  // namespace lec6::lec
