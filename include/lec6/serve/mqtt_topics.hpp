#pragma once
// The MQTT bridge's topic layout (docs/mqtt.md), in one place:
//
//   PREFIX/<bridge>/status              "online" / "offline", retained, last will
//   PREFIX/<line>/<axis>/state          telemetry JSON, retained
//   PREFIX/<line>/<axis>/availability   "online" / "offline", retained
//   PREFIX/<line>/<axis>/alarm          alarm events
//   PREFIX/<line>/<axis>/cmd            commands in
//   PREFIX/<line>/<axis>/result         command results out
//
// Line and axis names are letters, digits, '-' and '_' (config.hpp), so they
// never contain '/', '+' or '#'; the bridge's status has one level fewer than
// an axis topic, so the two never collide.
//
// Thread safety: plain values.

#include <optional>
#include <string>
#include <string_view>

namespace lec6::serve {

// What is wrong with `prefix` as the first levels of every topic (empty,
// wildcards, empty levels); nullopt when it is fine.
std::optional<std::string> check_topic_prefix(std::string_view prefix);

struct AxisTopic {
  std::string line, axis, leaf;  // leaf: state, cmd, result, ...
};

class MqttTopics {
 public:
  MqttTopics(std::string prefix, std::string bridge);

  std::string status() const;
  std::string axis(std::string_view line, std::string_view axis, std::string_view leaf) const;
  std::string state(std::string_view line, std::string_view axis) const {
    return this->axis(line, axis, "state");
  }
  std::string availability(std::string_view line, std::string_view axis) const {
    return this->axis(line, axis, "availability");
  }
  std::string alarm(std::string_view line, std::string_view axis) const {
    return this->axis(line, axis, "alarm");
  }
  std::string cmd(std::string_view line, std::string_view axis) const {
    return this->axis(line, axis, "cmd");
  }
  std::string result(std::string_view line, std::string_view axis) const {
    return this->axis(line, axis, "result");
  }
  // PREFIX/<line>/<axis>/<leaf> split up; nullopt for any other topic.
  std::optional<AxisTopic> parse(std::string_view topic) const;

  const std::string& prefix() const noexcept { return prefix_; }
  const std::string& bridge() const noexcept { return bridge_; }

 private:
  std::string prefix_, bridge_;
};

}  // namespace lec6::serve
