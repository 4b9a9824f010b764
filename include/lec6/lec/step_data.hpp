#pragma once
// Step data (manual §10.4) and direct-operation data (§10.2): the same
// sixteen-register record. Units are in the member names.
//
// Thread safety: value types and pure functions; const objects may be shared between threads,
// writes need the caller's synchronisation.

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "lec6/expected.hpp"

namespace lec6::lec {

enum class MovementMode : uint16_t {
  Blank = 0,        // a step that was never registered
  Absolute = 1,     // ABS: position is the target
  Incremental = 2,  // INC: position is added to the previous target
};

struct StepData {
  static constexpr std::size_t kRegisters = 16;

  MovementMode movement_mode = MovementMode::Blank;
  uint16_t speed_mm_s = 0;
  int32_t position_001mm = 0;  // target, or pushing start
  uint16_t acceleration_mm_s2 = 0;
  uint16_t deceleration_mm_s2 = 0;
  uint16_t pushing_force_pct = 0;  // 0 = positioning
  uint16_t trigger_level_pct = 0;
  uint16_t pushing_speed_mm_s = 0;
  uint16_t moving_force_pct = 0;  // max thrust while positioning
  int32_t area1_001mm = 0;
  int32_t area2_001mm = 0;
  int32_t in_position_001mm = 0;  // positioning: width; pushing: pushing distance

  // 32-bit values travel high word first, two's complement (digest §4).
  std::array<uint16_t, kRegisters> to_registers() const noexcept;
  // Reads the first 16 registers; missing ones read as 0.
  static StepData from_registers(std::span<const uint16_t> regs) noexcept;

  bool is_blank() const noexcept { return *this == StepData{}; }
  bool is_pushing() const noexcept { return pushing_force_pct > 0; }
  bool operator==(const StepData&) const = default;
};

// The fields, in register order, with what people need to read and type them.
enum class StepField : uint8_t {
  MovementMode,
  Speed,
  Position,
  Acceleration,
  Deceleration,
  PushingForce,
  TriggerLevel,
  PushingSpeed,
  MovingForce,
  Area1,
  Area2,
  InPosition,
};
inline constexpr std::size_t kStepFieldCount = 12;

struct StepFieldInfo {
  StepField field;
  std::string_view name;        // CLI name: "position", "push-speed"
  std::string_view long_name;   // the manual's: "pushing_speed"
  std::string_view csv_column;  // "pushing_speed_mm_s"
  std::string_view label;       // "Pushing speed"
  std::string_view unit;        // "mm", "mm/s", "mm/s²", "%", ""
  uint8_t offset;               // register offset in the record
  uint8_t registers;            // 1 or 2
  bool is_length;               // value in 0.01 mm, shown in mm
  int64_t min;                  // manual range, raw units
  int64_t max;
};

std::span<const StepFieldInfo> step_fields() noexcept;
const StepFieldInfo& field_info(StepField f) noexcept;
// Case-insensitive; accepts the CLI name, the manual's long name and the CSV
// column, with '-' or '_' ("push-speed", "pushing_speed", "PUSHING_SPEED_MM_S").
const StepFieldInfo* find_step_field(std::string_view name) noexcept;

int64_t get_field(const StepData& s, StepField f) noexcept;
void set_field(StepData& s, StepField f, int64_t raw) noexcept;

// "abs"/"inc"/"blank" for the mode, "150.00" for lengths, plain integers otherwise.
std::string format_field(StepField f, int64_t raw);
// Parses what a person typed for a field and checks the manual's range; the
// message names the field and the allowed range.
Expected<int64_t, std::string> parse_field(StepField f, std::string_view text);

struct ValidationIssue {
  StepField field;
  std::string message;  // "trigger level 80 % exceeds pushing force 50 %"
};

// Checks every field against the manual's ranges and the rules between
// fields. A blank record reports every field that must be set.
std::vector<ValidationIssue> validate(const StepData& s);

// The same, each message prefixed with "step N: " (or "direct operation: " for nullopt).
std::vector<std::string> validation_messages(const StepData& s, std::optional<unsigned> step);

// "movement mode", "speed", ... for a register offset 0–15 ("position (low word)").
std::string step_register_name(unsigned offset);

}  // namespace lec6::lec
