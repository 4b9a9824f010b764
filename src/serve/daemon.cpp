#include "lec6/serve/daemon.hpp"

#include <fmt/format.h>

#include <algorithm>

#include "cycles/cycle_service.hpp"
#include "history/history.hpp"
#include "history/state_dir.hpp"
#include "http/api/http_api.hpp"
#include "http/http_server.hpp"
#include "lec6/transport/capture_file.hpp"
#include "lec6/twin/line_recorder.hpp"
#include "line/line.hpp"
#include "line/wire.hpp"
#include "modbus_tcp/modbus_tcp_server.hpp"
#include "mqtt/mqtt_bridge.hpp"
#include "ops/axis_directory.hpp"
#include "ops/operations.hpp"
#include "sparkplug/edge_node.hpp"

namespace lec6::serve {
namespace {

const SteadyClock kClock;

GatewayPolicy policy_of(const LineConfig& line, const ListenerConfig& listener) {
  GatewayPolicy p;
  p.accept_fc06 = listener.fc06;
  for (const auto& a : line.axes) p.units.insert(a.id);
  p.allow_broadcast = line.allow_broadcast;
  p.cache_max_age = line.cache_max_age();
  p.read_retries = line.retries;
  return p;
}

}  // namespace

// The daemon as its front-ends see it.
class Daemon::Directory final : public AxisDirectory {
 public:
  explicit Directory(const Daemon& daemon) : daemon_(daemon) {}
  const std::vector<AxisRef>& axes() const override { return daemon_.axes_; }
  const std::vector<LineConfig>& lines() const override { return daemon_.config_.lines; }
  Line* line(std::string_view name) const override { return daemon_.line(name); }
  history::History* history() const override { return daemon_.history_.get(); }

 private:
  const Daemon& daemon_;
};

Daemon::Daemon(ServeConfig config, Log log)
    : config_(std::move(config)),
      log_(std::move(log)),
      directory_(std::make_unique<Directory>(*this)),
      stats_timer_(io_),
      stop_timer_(io_),
      signals_(io_),
      work_(asio::make_work_guard(io_)) {
  ops_ = std::make_unique<Operations>(log_);
  start_lines();
  start_history();              // issue 26
  if (!config_.cycles.empty())  // issue 34: before the listeners that offer them
    cycles_ = std::make_unique<CycleService>(*directory_, *ops_, config_.cycles, log_);
  start_listeners();
  if (config_.mqtt) {
    mqtt_ = std::make_unique<MqttBridge>(io_, *directory_, *ops_, *config_.mqtt, log_);
    mqtt_->start();
  }
  if (config_.sparkplug) {  // issue 35: bdSeq kept beside the history when there is one
    SparkplugConfig sp = *config_.sparkplug;
    // bdSeq is kept beside the history, else in the default state directory
    // (history off): a restart, after kill -9 too, births with the next one.
    std::filesystem::path dir = history_ ? history_->state_dir() : std::filesystem::path();
    if (dir.empty() && sp.bdseq_file.empty()) {
      if (const auto d = history::default_state_dir()) {
        std::error_code ec;
        std::filesystem::create_directories(d->dir, ec);
        if (!ec) dir = d->dir;
      }
      if (dir.empty()) {
        log_(LogLevel::Warning,
             "sparkplug: no state directory to keep bdSeq in: every start births with bdSeq 0 "
             "(set sparkplug.bdseq_file)");
      }
    }
    if (sp.bdseq_file.empty() && !dir.empty()) {  // one file per node: ids may change
      sp.bdseq_file =
          dir / fmt::format("sparkplug-{}-{}.bdseq", sp.group_id, sparkplug_edge_node_id(sp));
    }
    sparkplug_ = std::make_unique<SparkplugNode>(io_, *directory_, *ops_, sp, log_);
    sparkplug_->start();
  }
}

Daemon::~Daemon() {
  if (mqtt_) mqtt_->stop();
  if (sparkplug_) sparkplug_->stop();
  if (http_) http_->stop();
  for (auto& s : modbus_) s->stop();
  if (ops_) ops_->shutdown();
  for (auto& [name, line] : lines_) line->stop();
  if (ops_) ops_->shutdown();
}

void Daemon::start_lines() {
  for (const LineConfig& lc : config_.lines) {
    LineOptions o;
    o.name = lc.name;
    o.port = lc.port;
    o.scheduler = scheduler_config(lc);
    // --record: one capture per line for the daemon's life (reopens append to it).
    transport::LineTap record;
    if (!lc.record.empty()) {
      // An earlier capture is kept, never truncated (issue 33).
      if (const auto kept = transport::keep_earlier_capture(lc.record))
        log_(LogLevel::Info,
             fmt::format("line {}: kept the earlier capture {} as {}", lc.name, lc.record, *kept));
      auto rec = std::make_shared<twin::LineRecorder>(lc.record, "serve", lc.baud, lc.port, kClock);
      // A write that fails (a full disk) is said once; the line keeps working.
      rec->on_error([log = log_, name = lc.name](const std::string& why) {
        log(LogLevel::Error,
            fmt::format("line {}: recording stopped: {}; the line keeps working, its frames are no "
                        "longer recorded",
                        name, why));
      });
      record = [rec, tap = rec->tap()](transport::LineChunk&& c) { tap(std::move(c)); };
      log_(LogLevel::Info, fmt::format("line {}: recording every frame to {}", lc.name, lc.record));
    }
    auto line = std::make_unique<Line>(
        o, [lc, record] { return open_wire(lc, record); }, kClock);
    std::string ids;
    for (const auto& a : lc.axes)
      ids += fmt::format("{}{}={}", ids.empty() ? "" : ", ", a.name, a.id);
    log_(LogLevel::Info,
         fmt::format("line {} on {} @ {} baud: {}", lc.name, lc.port, lc.baud, ids));
    warn_if_telemetry_overfills(lc, o.scheduler);
    if (line->is_down()) {
      log_(LogLevel::Warning,
           fmt::format("line {} is down, retrying every second: {}", lc.name, line->down_reason()));
    }
    for (const AxisConfig& a : lc.axes) axes_.push_back(AxisRef{a.name, a.id, line.get(), &lc, &a});
    line->start();
    lines_.emplace(lc.name, std::move(line));
  }
}

// The move history (issue 26): fed by the operations and by each axis'
// telemetry; its own writer thread does the disk (history/store.hpp).
void Daemon::start_history() {
  if (!config_.history) return;
  std::vector<std::string> names;
  for (const auto& a : axes_) names.push_back(a.name);
  history_ = std::make_unique<history::History>(*config_.history, names, log_);
  history::History* h = history_.get();
  ops_->add_observer([h](const std::string& axis, const nlohmann::json& event) {
    h->on_op_event(axis, event, kClock.now());
  });
  for (const AxisRef& axis : axes_) {
    axis.line->add_observer([h, axis](const TelemetryEvent& e, const AxisSnapshot& s) {
      if (e.id != axis.id || (e.block != Block::State && e.block != Block::Flags)) return;
      AxisSnapshot read;  // only what this read brought: a sample is counted once
      if (e.block == Block::State) read.state = s.state;
      if (e.block == Block::Flags) read.flags = s.flags;
      h->on_telemetry(axis.name, read, e.at, e.started);
    });
  }
}

// Asking more telemetry than the line carries is legal (the scheduler shares
// what there is, and commands take turns with it), but then the configured
// rates are not what the axes get: say so, in numbers, at start.
void Daemon::warn_if_telemetry_overfills(const LineConfig& lc, const SchedulerConfig& s) {
  const double demand = telemetry_demand(s);
  if (demand <= 1.0) return;
  double fastest_hz = 0;
  for (const AxisConfig& a : lc.axes) fastest_hz = std::max(fastest_hz, a.telemetry_hz);
  log_(LogLevel::Info,
       fmt::format("line {}: telemetry at these rates needs {:.0f} % of the line at {} baud ({} "
                   "axes, up to {:g} Hz each): each axis refreshes at about {:.0f} % of its "
                   "telemetry_hz, and commands take turns with it",
                   lc.name, 100 * demand, lc.baud, lc.axes.size(), fastest_hz, 100 / demand));
}

void Daemon::start_listeners() {
  for (const LineConfig& lc : config_.lines) {
    Line& line = *lines_.at(lc.name);
    if (lc.modbus_tcp) {
      modbus_.push_back(std::make_unique<ModbusTcpServer>(io_, *lc.modbus_tcp,
                                                          ModbusTcpServer::Framing::Mbap, line,
                                                          policy_of(lc, *lc.modbus_tcp), log_));
    }
    if (lc.rtu_tcp) {
      modbus_.push_back(std::make_unique<ModbusTcpServer>(
          io_, *lc.rtu_tcp, ModbusTcpServer::Framing::Rtu, line, policy_of(lc, *lc.rtu_tcp), log_));
    }
  }
  if (config_.http) {
    api_ = std::make_unique<HttpApi>(*directory_, *ops_, *config_.http, log_, cycles_.get());
    HttpServerOptions o;
    o.log = [this](std::string text) { log_(LogLevel::Warning, text); };
    http_ = std::make_unique<HttpServer>(
        io_, config_.http->listener,
        [this](HttpRequest req, Responder res) { api_->handle(std::move(req), std::move(res)); },
        o);
    tick_stats();
  }
}

void Daemon::tick_stats() {
  stats_timer_.expires_after(std::chrono::seconds(1));
  stats_timer_.async_wait([this](const asio::error_code& ec) {
    if (ec || stopping_) return;
    api_->publish_stats();
    tick_stats();
  });
}

std::vector<std::string> Daemon::endpoints() const {
  std::vector<std::string> out;
  for (const auto& s : modbus_) out.push_back(s->url());
  if (http_) out.push_back("http://" + http_->address());
  if (mqtt_) out.push_back(mqtt_->describe());
  if (sparkplug_) out.push_back(sparkplug_->describe());
  return out;
}

const AxisRef* Daemon::axis(std::string_view name) const {
  return directory_->axis(name);
}

const AxisDirectory& Daemon::directory() const noexcept {
  return *directory_;
}

Line* Daemon::line(std::string_view name) const {
  const auto it = lines_.find(name);
  return it == lines_.end() ? nullptr : it->second.get();
}

// On the event loop's thread, and it does not block it: while lec serve
// shuts down, stop, hold and reset are still taken from every channel (issue
// 31 rule 4). First every line takes only stops and fails its other queued
// jobs, operations take only stops and release jogs; the front-ends keep
// listening until the operations have ended (at most kStopGrace); then they
// close, and the lines send the stops still queued before they close.
namespace {
constexpr auto kStopGrace = std::chrono::seconds(5);
constexpr auto kStopPoll = std::chrono::milliseconds(20);
}  // namespace

void Daemon::begin_stop() {
  if (stopping_) return;
  stopping_ = true;
  stop_began_ = std::chrono::steady_clock::now();
  log_(LogLevel::Info, "stopping: only stop, hold and reset are taken now");
  signals_.cancel();
  stats_timer_.cancel();
  for (auto& [name, line] : lines_) line->begin_stop();
  ops_->begin_shutdown();  // hold-to-run jogs are released while the lines still run
  finish_stop_when_idle();
}

void Daemon::finish_stop_when_idle() {
  if (ops_->idle() || std::chrono::steady_clock::now() - stop_began_ >= kStopGrace)
    return finish_stop();
  stop_timer_.expires_after(kStopPoll);
  stop_timer_.async_wait([this](const asio::error_code& ec) {
    if (!ec) finish_stop_when_idle();
  });
}

// Lines stop after the listeners stop accepting, so every queued job is
// answered (with an error) before connections close.
void Daemon::finish_stop() {
  if (finished_) return;
  finished_ = true;
  log_(LogLevel::Info, "stopping: finishing the transactions on the wire");
  for (auto& s : modbus_) s->shutdown();
  if (mqtt_) mqtt_->stop();                        // "offline" goes out; the will is for a crash
  if (sparkplug_) sparkplug_->stop();              // NDEATH, then DISCONNECT
  for (auto& [name, line] : lines_) line->stop();  // the stops still queued go out first
  ops_->shutdown();  // operations end on "shutting down"; their HTTP answers go out
  if (http_) http_->stop();
  work_.reset();
  // Connections close as their last answers are written; then run() returns.
}

int Daemon::run(bool handle_signals) {
  if (handle_signals) {
    signals_.add(SIGINT);
    signals_.add(SIGTERM);
    signals_.async_wait([this](const asio::error_code& ec, int signal) {
      if (ec) return;
      log_(LogLevel::Info, fmt::format("{} received", signal == SIGTERM ? "SIGTERM" : "SIGINT"));
      begin_stop();
    });
  }
  io_.run();
  return 0;
}

void Daemon::stop() {
  asio::post(io_, [this] { begin_stop(); });
}

}  // namespace lec6::serve
