#pragma once
// The order in which lec serve puts requests on a line (issue: the scheduler).

#include <array>
#include <cstddef>
#include <cstdint>
#include <string_view>

namespace lec6::serve {

enum class Priority : uint8_t {
  Emergency = 0,   // stop, hold and emergency writes
  Command = 1,     // client commands (Modbus TCP, HTTP, MQTT, CLI)
  Completion = 2,  // polling for a move's completion
  Telemetry = 3,   // the periodic state reads, round-robin over IDs
  Background = 4,  // alarm history and other slow reads
};
inline constexpr std::size_t kPriorities = 5;

constexpr std::size_t index(Priority p) noexcept {
  return static_cast<std::size_t>(p);
}

// "emergency", "command", ... (metrics labels, API keys).
constexpr std::string_view priority_name(Priority p) noexcept {
  constexpr std::array<std::string_view, kPriorities> kNames{"emergency", "command", "completion",
                                                             "telemetry", "background"};
  return kNames[index(p)];
}

}  // namespace lec6::serve
