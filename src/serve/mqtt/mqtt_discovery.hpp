#pragma once
// Home Assistant MQTT discovery for one axis (mqtt.home_assistant: true):
// retained config messages under homeassistant/ that make the axis a device
// with sensors (position, speed, thrust), binary sensors (the main flags)
// and buttons (home, stop). Every entity is available only while the bridge
// is online and the axis answers (both availability topics).
//
// Thread safety: pure functions.

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "lec6/serve/mqtt_topics.hpp"

namespace lec6::serve {

struct Publication {
  std::string topic;
  nlohmann::json payload;
};

inline constexpr const char* kHomeAssistantPrefix = "homeassistant";

// The discovery messages of one axis (publish them retained).
std::vector<Publication> home_assistant_discovery(const MqttTopics& topics, const std::string& line,
                                                  const std::string& axis, int controller_id);

}  // namespace lec6::serve
