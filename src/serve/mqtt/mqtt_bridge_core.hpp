#pragma once
// The MQTT bridge's insides (private to serve/): telemetry publishing in
// mqtt_bridge.cpp, commands in mqtt_bridge_commands.cpp.

#include <asio.hpp>

#include <atomic>
#include <chrono>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "lec6/serve/daemon.hpp"
#include "lec6/serve/mqtt_topics.hpp"
#include "line/line.hpp"
#include "mqtt/mqtt_bridge.hpp"
#include "mqtt/mqtt_client.hpp"
#include "mqtt/mqtt_command.hpp"
#include "mqtt/mqtt_dedup.hpp"
#include "ops/operations.hpp"

namespace lec6::serve {
namespace history {
class History;
}

struct MqttBridge::Core : std::enable_shared_from_this<MqttBridge::Core> {
  Core(Daemon& daemon, Operations& ops, const MqttConfig& config, Log log);

  // What the bridge keeps per axis.
  struct AxisOut {
    std::string state, availability, alarm, cmd, result;  // topics
    std::atomic<bool> wake{false};                        // a publish is posted and has not run yet
    // Event loop only:
    std::optional<bool> online;  // the availability last published
    std::set<int> alarms;        // the alarm codes active at the last publish
  };

  void start();
  void stop();

  // Telemetry (mqtt_bridge.cpp).
  void connected();
  void republish();
  void tick();
  void wake(std::size_t axis);
  void publish_axis(std::size_t axis, bool force);
  void alarm_events(std::size_t axis, const nlohmann::json& alarms, double at);

  // Commands (mqtt_bridge_commands.cpp).
  void command(const MqttMessage& message);
  void finished(std::size_t axis, const nlohmann::json& id, const std::string& key,
                const OpResult& result);
  void refuse(std::size_t axis, const EnvelopeError& error, const std::vector<ReplyTo>& to);
  void reply(std::size_t axis, const std::string& payload, const std::vector<ReplyTo>& to);

  asio::io_context& io;
  Operations& ops;
  MqttConfig config;
  Log log;
  MqttTopics topics;
  std::vector<AxisRef> axes;
  std::vector<std::unique_ptr<AxisOut>> out;
  std::map<std::string, std::size_t, std::less<>> by_cmd_topic;
  std::mutex commands_mutex;
  std::vector<CommandLog> commands;  // per axis
  std::unique_ptr<MqttClient> client;
  asio::steady_timer timer;
  std::chrono::steady_clock::time_point next_tick{};
  std::atomic<bool> stopped{false};
  history::History* history = nullptr;  // issue 26: .../history and .../health (retained)
};

double unix_now();

}  // namespace lec6::serve
