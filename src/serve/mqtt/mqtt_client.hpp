#pragma once
// A thin MQTT 5 client over libmosquitto for the bridge: one thread of its
// own runs the network loop, connects, and reconnects with exponential
// back-off (1 s doubling to reconnect_max_s) whatever the failure (refused,
// DNS, TLS, bad credentials), so a broker outage never ends the bridge.
//
// publish() never blocks: it hands the message to libmosquitto's queue, which
// this client's thread writes. That queue is bounded here: at most
// `max_pending` messages written to no socket yet (QoS 0) or unacknowledged
// (QoS 1); past that, and for QoS 0 while disconnected, a publish is dropped
// and counted. The bridge's telemetry is superseded by the next sample anyway.
//
// The session is clean (nothing kept at the broker while we are away), and
// subscriptions ask for retain-as-published and no retained messages on
// subscribe, so a retained command is seen as retained (and refused).
//
// Thread safety: publish(), subscribe(), connected() and stats() from any
// thread; handlers run on the client's thread and must be quick.

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "lec6/clock.hpp"
#include "lec6/serve/config.hpp"
#include "mqtt/mqtt_dedup.hpp"

namespace lec6::serve {

struct MqttMessage {
  std::string topic;
  std::string payload;
  bool retain = false;
  std::optional<std::string> response_topic;  // MQTT 5 request/response
  std::optional<std::string> correlation;     // binary, echoed with the response
  std::optional<uint32_t> expiry_s;           // message expiry left
};

struct MqttClientOptions {
  BrokerUrl url;
  std::string client_id;
  std::string username, password;
  std::string ca_file, cert_file, key_file;
  unsigned keepalive_s = 30;
  unsigned reconnect_max_s = 30;
  std::string will_topic, will_payload;  // retained, QoS 1
  std::size_t max_pending = 8192;
  std::string thread_name = "lec-mqtt";  // the network thread's, ≤ 15 characters (top -H, /proc)
  // Sparkplug B (src/serve/sparkplug/): its NDEATH will and its last message
  // are not retained; the will's payload changes before every CONNECT (a new
  // bdSeq: will_update, called on the client's thread); and STATE, a retained
  // message, must be delivered on subscribe (integration.sparkplug_host):
  // the filters in `retained_filters` get the retained messages stored,
  // every other filter never does (a stale command must not arrive).
  bool will_retain = true;
  std::function<std::string()> will_update;
  bool last_retain = true;  // stop()'s last messages
  // Their QoS. 1: acknowledged (stop() waits its grace for the PUBACKs). 0:
  // they go out ahead of the DISCONNECT whatever is in flight; a QoS 1 one
  // waits behind the broker's receive maximum (20 in flight) and a DISCONNECT
  // overtakes it: the bridge's retained "offline" status was lost so, the
  // will (also "offline") not published either after a clean DISCONNECT.
  int last_qos = 1;
  // How long a reconnect() waits for what is in flight before its DISCONNECT.
  Duration redial_drain = std::chrono::seconds(10);
  std::vector<std::string> retained_filters;
};

struct MqttClientHandlers {
  std::function<void()> connected;
  std::function<void(const std::string& why)> disconnected;  // also a refused connection
  std::function<void(const MqttMessage&)> message;
};

struct MqttClientStats {
  bool connected = false;
  uint64_t connects = 0;
  uint64_t published = 0;
  uint64_t dropped = 0;  // the pending bound, or QoS 0 while disconnected
  uint64_t received = 0;
  std::size_t pending = 0;
};

// What the bridge needs of a connection to the broker: an MqttClient, or a
// test's fake (tests/serve/mqtt/mqtt_bridge_test.cpp) that records what is
// published and hands the bridge messages as the broker would.
class MqttSession {
 public:
  virtual ~MqttSession() = default;

  virtual void start() = 0;
  // False when dropped (see above). `reply` adds the MQTT 5 correlation data.
  virtual bool publish(const std::string& topic, std::string_view payload, int qos, bool retain,
                       const ReplyTo* reply = nullptr) = 0;
  virtual void subscribe(const std::vector<std::string>& filters) = 0;
  // Publishes `last` (QoS 1, retained) when connected and waits, at most
  // `grace`, for the broker to acknowledge them; then disconnects cleanly
  // and joins the thread. Idempotent.
  virtual void stop(const std::vector<std::pair<std::string, std::string>>& last,
                    Duration grace) = 0;
  virtual bool connected() const = 0;
};

// Makes the bridge's session; the handlers are the bridge's.
using MqttSessionFactory =
    std::function<std::unique_ptr<MqttSession>(MqttClientOptions, MqttClientHandlers)>;

class MqttClient final : public MqttSession {
 public:
  // Throws std::runtime_error when libmosquitto refuses the settings (TLS files).
  MqttClient(MqttClientOptions options, MqttClientHandlers handlers);
  ~MqttClient() override;
  MqttClient(const MqttClient&) = delete;
  MqttClient& operator=(const MqttClient&) = delete;

  void start() override;
  bool publish(const std::string& topic, std::string_view payload, int qos, bool retain,
               const ReplyTo* reply = nullptr) override;
  void subscribe(const std::vector<std::string>& filters) override;
  void stop(const std::vector<std::pair<std::string, std::string>>& last, Duration grace) override;

  bool connected() const override;
  MqttClientStats stats() const;
  // Ends this connection (DISCONNECT) and connects again at once, with a
  // fresh will (Sparkplug: the primary host went offline). The DISCONNECT
  // waits (≤ 10 s) for what is in flight, so no QoS 1 message is sent again on
  // the next connection (integration.sparkplug_host: lec6-one-ndeath-per-bdseq).
  void reconnect();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace lec6::serve
