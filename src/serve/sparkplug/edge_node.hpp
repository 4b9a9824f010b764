#pragma once
// lec serve as a Sparkplug B edge node (docs/sparkplug.md): the node is the
// daemon, each axis a device. The rules live in the sans-I/O session
// (session.hpp); this is its MQTT glue over the bridge's client
// (mqtt/mqtt_client.hpp, libmosquitto) and its feed from the lines and
// Operations:
//
//   - values are sampled at sparkplug.telemetry_hz from the telemetry cache
//     (the node never polls the line itself) and at once when an axis'
//     flags, health or alarms change; the session publishes what changed;
//   - a DCMD is checked (session.hpp, dcmd.hpp) and run by Operations on the
//     client's thread, as the MQTT bridge runs its commands: a stop goes to
//     the line's emergency lane without waiting for anything;
//   - bdSeq is kept in a file (sparkplug.bdseq_file), so a restart, even
//     after kill -9, births with the next one.
//
// Proven against mosquitto by an independent host (tests/sparkplug_host/host.mjs,
// integration.sparkplug_host, which also checks that a flag change goes out at
// once on a node comparing every 5 s).
//
// Thread safety: construct, start() and stop() on the event loop's thread.

#include <memory>
#include <string>

#include "lec6/serve/config.hpp"
#include "lec6/serve/log.hpp"

namespace asio {
class io_context;
}

namespace lec6::serve {

class AxisDirectory;
class Operations;

class SparkplugNode {
 public:
  SparkplugNode(asio::io_context& io, const AxisDirectory& directory, Operations& ops,
                const SparkplugConfig& config, Log log);
  ~SparkplugNode();
  SparkplugNode(const SparkplugNode&) = delete;
  SparkplugNode& operator=(const SparkplugNode&) = delete;

  // Connects (in the background, retrying) and starts publishing. Throws
  // std::runtime_error when libmosquitto refuses the settings (TLS files).
  void start();
  // NDEATH, then DISCONNECT (waits ≤ 2 s for the broker to take it).
  void stop();

  // "sparkplug mqtt://127.0.0.1:1883 (spBv1.0/lec6/.../box7)"
  std::string describe() const;

  struct Core;

 private:
  std::shared_ptr<Core> core_;
};

// The edge node id when the config leaves it out: the host name.
std::string sparkplug_edge_node_id(const SparkplugConfig& config);

}  // namespace lec6::serve
