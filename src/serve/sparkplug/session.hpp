#pragma once
// A Sparkplug B edge node's session (Eclipse Sparkplug 3.0), sans I/O: it is
// told what happened (connected, a message arrived, the values now, the time
// in UTC ms) and answers with the messages to publish; the MQTT glue
// (edge_node.hpp) does the network. Tested on a virtual clock
// (tests/serve/sparkplug/session_test.cpp).
//
//   - bdSeq: 0 for a node with no previous session, else the last one + 1,
//     wrapping 255 -> 0; will() advances it before every MQTT CONNECT and
//     returns the NDEATH to register as the will (QoS 1, not retained,
//     bdSeq alone). The NBIRTH that follows carries the same bdSeq, and so
//     does a rebirth's.
//   - seq: 0 in every NBIRTH, then +1 per message of the node (DBIRTH,
//     NDATA, DDATA, DDEATH), wrapping 255 -> 0; NDEATH has none.
//   - aliases: every metric but bdSeq and Node Control/Rebirth has one,
//     unique across the node and its devices; births carry names, aliases,
//     datatypes and current values; data messages aliases and values only
//     (and the datatype: see docs/sparkplug.md).
//   - report by exception: NDATA / DDATA carry the metrics whose value
//     changed since they were last published in this session.
//   - devices: DBIRTH when a device is online (after the NBIRTH), DDEATH when
//     it goes offline, DBIRTH again when it is back.
//   - NCMD Node Control/Rebirth = true: NBIRTH and DBIRTHs again, same bdSeq.
//   - with a primary host: births wait for its STATE {"online": true}; a
//     STATE online=false (not older than the last one seen) means NDEATH and
//     reconnect.
//   - DCMD: every metric resolved (alias or name), writable, of a compatible
//     type, or the whole command is refused with the reason. A stop
//     (Command/Stop = true) goes whatever else the DCMD holds and whether or
//     not the node is born; any other DCMD is refused while the node is not
//     born (not connected, or waiting for the primary host).
//   - rebirth(): the births again (same bdSeq, seq 0), for a node that lost
//     a message it had numbered (a publish the client could not queue).
//
// Thread safety: none; one owner, except stop_request(), which reads only
// what the constructor set and may be called from any thread at any time.

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "sparkplug/payload.hpp"

namespace lec6::serve::sparkplug {

inline constexpr std::string_view kNamespace = "spBv1.0";
inline constexpr std::string_view kRebirth = "Node Control/Rebirth";
inline constexpr std::string_view kBdSeq = "bdSeq";
// A command is a few hundred bytes (every command metric by name: ~600). A
// bigger NCMD or DCMD is refused unread: decoding megabytes held every stop
// behind it for seconds (SparkplugPayloadFuzz.ABigDcmdDoesNotHoldTheStopBehindIt).
inline constexpr std::size_t kMaxCommandBytes = 16 * 1024;

struct MetricDef {
  std::string name;
  DataType type = DataType::Double;
  bool writable = false;  // a DCMD may write it
};

struct DeviceDef {
  std::string id;  // the device_id in its topics
  std::vector<MetricDef> metrics;
};

struct SessionConfig {
  std::string group_id;
  std::string edge_node_id;
  std::string primary_host_id;          // empty: births do not wait for a host
  std::vector<MetricDef> node_metrics;  // besides bdSeq and Node Control/Rebirth
  std::vector<DeviceDef> devices;
};

struct Message {
  std::string topic;
  std::string payload;
  int qos = 0;
  bool retain = false;
};

// A DCMD that passed every check: the writes, in the command's order.
struct Write {
  std::size_t metric;  // index into the device's metrics
  Value value;
};
struct DeviceCommand {
  std::size_t device;
  std::vector<Write> writes;
};
struct Refusal {
  std::size_t device;
  std::string why;
};

class EdgeSession {
 public:
  // `last_bdseq`: the bdSeq of the previous run (kept on disk), if any.
  EdgeSession(SessionConfig config, std::optional<uint8_t> last_bdseq);

  const SessionConfig& config() const noexcept { return config_; }
  // NCMD, DCMD of every device, and the primary host's STATE.
  std::vector<std::string> subscriptions() const;
  std::string topic(std::string_view verb, const std::string* device = nullptr) const;

  // Before an MQTT CONNECT: bdSeq advances; the NDEATH to register as the will.
  Message will();
  uint8_t bdseq() const noexcept { return bdseq_; }
  uint64_t alias_of_node(std::size_t metric) const noexcept { return metric + 1; }
  uint64_t alias_of(std::size_t device, std::size_t metric) const;

  // The MQTT session is up: the births, unless a primary host must say online first.
  std::vector<Message> connected(uint64_t now_ms);
  void disconnected();
  bool born() const noexcept { return born_; }
  bool waiting_for_host() const noexcept { return connected_ && !born_; }

  struct Reaction {
    std::vector<Message> out;
    bool reconnect = false;  // the primary host is offline: `out` has the NDEATH; drop the session
    std::optional<DeviceCommand> command;
    std::optional<Refusal> refused;
    std::string note;  // what was ignored and why (for the log)
  };
  Reaction received(std::string_view topic, std::string_view payload, bool retained,
                    uint64_t now_ms);

  // The device a DCMD topic names (const and lock-free, as stop_request()).
  std::optional<std::size_t> device_of_dcmd(std::string_view topic) const;

  // A DCMD on `topic` holding Command/Stop = true (not retained): its device.
  // Const and lock-free, so a stop is found without waiting for the owner.
  std::optional<std::size_t> stop_request(std::string_view topic, std::string_view payload,
                                          bool retained) const;

  // The births again when born (NBIRTH with the same bdSeq, seq 0, then DBIRTHs).
  std::vector<Message> rebirth(uint64_t now_ms);

  // The values now (one per metric, in the definitions' order); what changed is published.
  std::vector<Message> node_values(std::vector<Value> values, uint64_t now_ms);
  std::vector<Message> device_values(std::size_t device, bool online, std::vector<Value> values,
                                     uint64_t now_ms);

  // An intentional end (tck-id-operational-behavior-edge-node-intentional-disconnect-ndeath):
  // the NDEATH to publish before the DISCONNECT, unless this bdSeq's death was
  // said already (the primary host went offline just before): a session dies
  // once. The session is no longer born.
  std::optional<Message> goodbye(uint64_t now_ms);

 private:
  struct Device {
    bool online = false;
    bool born = false;
    std::vector<Value> now, sent;
  };
  std::vector<Message> births(uint64_t now_ms);
  Message dbirth(std::size_t d, uint64_t now_ms);
  Message ndeath(std::optional<uint64_t> now_ms) const;
  Reaction state(std::string_view payload, uint64_t now_ms);
  Reaction ncmd(std::string_view payload, bool retained, uint64_t now_ms);
  Reaction dcmd(std::size_t d, std::string_view payload, bool retained);
  std::optional<std::size_t> metric_index(std::size_t d, const Metric& m) const;
  bool is_stop(std::size_t d, const Metric& m) const;
  uint64_t next_seq();

  SessionConfig config_;
  std::vector<uint64_t> alias_base_;  // per device: the alias of its first metric
  std::optional<uint8_t> last_bdseq_;
  uint8_t bdseq_ = 0;
  uint8_t seq_ = 0;
  bool connected_ = false;
  bool born_ = false;
  bool death_said_ = false;                // goodbye() published this bdSeq's NDEATH
  std::optional<uint64_t> host_state_ms_;  // the newest STATE timestamp seen
  std::vector<Value> node_now_, node_sent_;
  std::vector<Device> devices_;
};

// Whether `value` may be written to a metric of type `type` (Boolean takes
// only booleans, integer types integers, Float/Double numbers, String text).
bool compatible(DataType type, const Value& value);

}  // namespace lec6::serve::sparkplug
