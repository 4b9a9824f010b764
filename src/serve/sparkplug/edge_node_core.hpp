#pragma once
// The edge node's insides (private to serve/): session, values and MQTT in
// edge_node.cpp, DCMDs in edge_node_commands.cpp.

#include <asio.hpp>

#include <atomic>
#include <chrono>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "mqtt/mqtt_client.hpp"
#include "ops/axis_directory.hpp"
#include "ops/operations.hpp"
#include "sparkplug/dcmd.hpp"
#include "sparkplug/edge_node.hpp"
#include "sparkplug/session.hpp"

namespace lec6::serve {

using sparkplug::CommandState;
using sparkplug::DeviceCommand;
using sparkplug::EdgeSession;
using sparkplug::Message;

struct SparkplugNode::Core : std::enable_shared_from_this<SparkplugNode::Core> {
  Core(asio::io_context& io, const AxisDirectory& directory, Operations& ops,
       const SparkplugConfig& config, Log log);

  void start();
  void stop();
  void tick();
  void wake(std::size_t axis);
  // Under `mutex`:
  void sample_axis(std::size_t axis, uint64_t now_ms);
  void sample_node(uint64_t now_ms);
  void publish(const std::vector<Message>& out);
  void on_connected();
  void on_message(const MqttMessage& m);
  // `stops_seen`: the axis' stop count when the DCMD arrived (nothing runs
  // after a stop that came later).
  void command(const DeviceCommand& c, uint64_t stops_seen);
  // A DCMD stop, found without the mutex: to the emergency lane first.
  void stop_now(std::size_t axis);
  int64_t number(std::size_t axis);  // the next DCMD number of the axis (lock-free)
  void refuse(std::size_t axis, const std::string& why);
  void refuse_locked(std::size_t axis, int64_t count, const std::string& why);  // under `mutex`
  void finished(std::size_t axis, int64_t count, const OpResult& r, bool stop = false);
  // A message that is not a DCMD stop, on the event loop's thread (posted by
  // on_message); `stops_seen`: the axis' stop count when it arrived.
  void handle(const MqttMessage& m, std::vector<uint64_t> stops_seen);

  asio::io_context& io;
  const AxisDirectory& directory;
  Operations& ops;
  SparkplugConfig config;
  Log log;
  std::vector<AxisRef> axes;
  bool history_on = false;
  std::size_t command_offset = 0;  // where command_metrics() start in an axis' metrics
  std::unique_ptr<MqttClient> client;
  asio::steady_timer timer;
  std::chrono::steady_clock::time_point next_tick{}, next_node{};
  std::vector<std::unique_ptr<std::atomic<bool>>> woken;
  std::vector<std::unique_ptr<std::atomic<int64_t>>> numbered;  // DCMDs per axis
  std::vector<std::unique_ptr<std::atomic<uint64_t>>> stops;    // DCMD stops per axis
  std::atomic<bool> stopped{false};

  std::mutex mutex;  // the session, the command states, the caches; held while publishing
  std::unique_ptr<EdgeSession> session;
  std::vector<CommandState> commands;
  std::vector<std::optional<nlohmann::json>> health;  // per axis, refreshed with the node's metrics
  std::vector<std::string> health_text;               // the same, dumped
  bool bdseq_warned = false;  // the bdSeq file could not be written (said once)
  bool rebirth_due = false;   // a numbered message was not queued: births again at the next tick
  // The node's own CPU (sampling, encoding, queueing), for the benchmark and the stop's log line.
  std::atomic<uint64_t> cpu_ns{0};
  std::atomic<uint64_t> published{0};
  std::atomic<uint64_t> connects{0};  // MQTT sessions so far (messages are tagged with theirs)
};

// CPU time of the calling thread, in ns.
uint64_t sparkplug_thread_cpu_ns();

// Adds the calling thread's CPU time from construction to destruction to `total`.
struct CpuSpan {
  explicit CpuSpan(std::atomic<uint64_t>& total) : total_(total), t0_(sparkplug_thread_cpu_ns()) {}
  ~CpuSpan() { total_ += sparkplug_thread_cpu_ns() - t0_; }
  CpuSpan(const CpuSpan&) = delete;
  CpuSpan& operator=(const CpuSpan&) = delete;

 private:
  std::atomic<uint64_t>& total_;
  uint64_t t0_;
};

uint64_t sparkplug_unix_ms();

}  // namespace lec6::serve
