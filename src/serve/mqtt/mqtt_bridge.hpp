#pragma once
// The MQTT bridge inside lec serve (docs/mqtt.md): every axis' telemetry out
// to a broker, commands in, results back, for SCADA, historians and
// dashboards that know the broker and not where each box is.
//
//   - state: the latest cached telemetry (views.hpp's telemetry_json), at
//     mqtt.telemetry_hz per axis and at once on a flag change, retained, QoS 0:
//     the bridge never polls the line, it publishes what the line's own
//     telemetry last read; a sample that cannot go out is superseded.
//   - availability: the bridge's status (retained, the last will) and each
//     axis' (retained, from the line's health), QoS 1.
//   - alarm: an event when an alarm code appears or clears, QoS 1.
//   - commands (mqtt_command.hpp): checked completely, deduplicated by id
//     (mqtt_dedup.hpp), run by Operations at client priority, one motion per
//     axis; the result goes to .../result (QoS 1) and to the MQTT 5 response
//     topic when the request names one.
//
// The line threads never wait on the broker: their telemetry observer only
// posts a wake-up (one per axis at most) to the daemon's event loop, which
// publishes into the client's bounded queue (mqtt_client.hpp).
//
// Thread safety: construct, start() and stop() on the event loop's thread.

#include <memory>
#include <string>

#include "lec6/serve/config.hpp"
#include "lec6/serve/log.hpp"

namespace lec6::serve {

class Daemon;
class Operations;

class MqttBridge {
 public:
  MqttBridge(Daemon& daemon, Operations& ops, const MqttConfig& config, Log log);
  ~MqttBridge();
  MqttBridge(const MqttBridge&) = delete;
  MqttBridge& operator=(const MqttBridge&) = delete;

  // Connects (in the background, retrying) and starts publishing. Throws
  // std::runtime_error when libmosquitto refuses the settings (TLS files).
  void start();
  // Publishes "offline" for the bridge and its axes, waits (≤ 2 s) for the
  // broker to take it, and disconnects. Results of operations still running
  // are not published after this.
  void stop();

  // "mqtt://127.0.0.1:1883 (bridge lec6-box7, prefix lec6)"
  std::string describe() const;

  struct Core;

 private:
  std::shared_ptr<Core> core_;
};

// The client id and the bridge name when the config leaves them out:
// "lec6-<host name>", and the client id.
std::string mqtt_client_id(const MqttConfig& config);
std::string mqtt_bridge_name(const MqttConfig& config);

}  // namespace lec6::serve
