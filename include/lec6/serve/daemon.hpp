#pragma once
// `lec serve`: one process owns each configured line and lets every
// front-end share it (Modbus TCP, RTU over TCP, HTTP, MQTT).
//
// Threads: one per line (serve::Line, the only one touching its wire), one
// for the event loop (standalone Asio: listeners, connections, timers), and
// one per running axis operation (operations block on their line's answers),
// and the MQTT client's (mqtt_bridge.hpp).
//
// Stopping (SIGTERM, SIGINT, stop()): listeners stop accepting, each line
// finishes the transaction on the wire and fails its queued jobs (masters
// get exception 06, HTTP clients 503), connections close once answered, and
// run() returns 0.
//
// Thread safety: stop() from any thread (and from signal handlers through
// the event loop); the rest from the thread that made the daemon.

#include <asio.hpp>

#include <map>
#include <memory>
#include <string>
#include <vector>

#include "lec6/serve/config.hpp"
#include "lec6/serve/log.hpp"

namespace lec6::serve {

class Line;
struct SchedulerConfig;
struct AxisRef;       // src/serve/ops/axis_directory.hpp
class AxisDirectory;  // what the front-ends see of the daemon
class ModbusTcpServer;
class HttpServer;
class HttpApi;
class MqttBridge;
class SparkplugNode;  // issue 35
class Operations;
class CycleService;  // issue 34
namespace history {
class History;
}

class Daemon {
 public:
  // Opens every line (a line whose port cannot be opened starts down and
  // keeps trying) and binds every listener (throws when one cannot bind).
  Daemon(ServeConfig config, Log log);
  ~Daemon();
  Daemon(const Daemon&) = delete;
  Daemon& operator=(const Daemon&) = delete;

  // Serves until stop() or, with `handle_signals`, SIGTERM/SIGINT.
  // Returns 0 after a clean stop.
  int run(bool handle_signals = true);
  void stop();

  // What listens where: "line1 Modbus TCP tcp://127.0.0.1:1502", ...
  std::vector<std::string> endpoints() const;
  const ServeConfig& config() const noexcept { return config_; }
  const std::vector<AxisRef>& axes() const noexcept { return axes_; }
  const AxisRef* axis(std::string_view name) const;
  Line* line(std::string_view name) const;
  asio::io_context& io() noexcept { return io_; }
  Operations& operations() noexcept { return *ops_; }
  // The HTTP API, when an HTTP listener is configured.
  HttpApi* http_api() noexcept { return api_.get(); }
  // The move history (issue 26), when configured (history: / --state-dir).
  history::History* history() noexcept { return history_.get(); }
  // What the front-ends are given instead of the daemon: its axes, lines and history.
  const AxisDirectory& directory() const noexcept;

 private:
  void start_lines();
  void warn_if_telemetry_overfills(const LineConfig& lc, const SchedulerConfig& s);
  void start_listeners();
  void start_history();
  void begin_stop();
  void tick_stats();

  class Directory;

  ServeConfig config_;
  Log log_;
  std::unique_ptr<Directory> directory_;
  // Before everything that feeds it, so that it goes last.
  std::unique_ptr<history::History> history_;
  asio::io_context io_;
  std::map<std::string, std::unique_ptr<Line>, std::less<>> lines_;
  std::vector<AxisRef> axes_;
  std::vector<std::unique_ptr<ModbusTcpServer>> modbus_;
  std::unique_ptr<Operations> ops_;
  std::unique_ptr<CycleService> cycles_;  // issue 34: machine cycles (serve/cycles/)
  std::unique_ptr<HttpApi> api_;
  std::unique_ptr<HttpServer> http_;
  std::unique_ptr<MqttBridge> mqtt_;
  std::unique_ptr<SparkplugNode> sparkplug_;  // issue 35
  asio::steady_timer stats_timer_;
  // Shutting down: the grace in which stops are still taken (finish_stop()).
  asio::steady_timer stop_timer_;
  std::chrono::steady_clock::time_point stop_began_{};
  asio::signal_set signals_;
  // Keeps run() going until stop, whatever listens.
  asio::executor_work_guard<asio::io_context::executor_type> work_;
  bool stopping_ = false;
  bool finished_ = false;
  void finish_stop_when_idle();
  void finish_stop();
};

}  // namespace lec6::serve
