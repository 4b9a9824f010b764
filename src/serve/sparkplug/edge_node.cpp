#include "sparkplug/edge_node.hpp"

#include <fmt/format.h>
#include <time.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <fstream>
#include <map>
#include <mutex>

#include "history/history.hpp"
#include "line/line.hpp"
#include "mqtt/mqtt_client.hpp"
#include "ops/axis_directory.hpp"
#include "ops/operations.hpp"
#include "ops/views.hpp"
#include "sparkplug/catalogue.hpp"
#include "sparkplug/dcmd.hpp"
#include "sparkplug/edge_node_core.hpp"
#include "sparkplug/session.hpp"

namespace lec6::serve {

using namespace sparkplug;
using nlohmann::json;

namespace {

constexpr Duration kStopGrace = std::chrono::seconds(2);

uint64_t unix_ms() {
  return static_cast<uint64_t>(std::chrono::duration_cast<std::chrono::milliseconds>(
                                   std::chrono::system_clock::now().time_since_epoch())
                                   .count());
}

std::optional<uint8_t> read_bdseq(const std::filesystem::path& file) {
  if (file.empty()) return std::nullopt;
  std::ifstream in(file);
  int v = -1;
  if (!(in >> v) || v < 0 || v > 255) return std::nullopt;
  return static_cast<uint8_t>(v);
}

// False when the file could not be written (the directory gone, the disk full).
bool write_bdseq(const std::filesystem::path& file, uint8_t v) {
  if (file.empty()) return true;
  const auto tmp = file.string() + ".tmp";
  {
    std::ofstream out(tmp, std::ios::trunc);
    out << static_cast<int>(v) << "\n";
    out.flush();
    if (!out) return false;
  }
  std::error_code ec;
  std::filesystem::rename(tmp, file, ec);
  return !ec;
}

}  // namespace

uint64_t sparkplug_unix_ms() {
  return unix_ms();
}

uint64_t sparkplug_thread_cpu_ns() {
  timespec ts{};
  ::clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<uint64_t>(ts.tv_sec) * 1'000'000'000u + static_cast<uint64_t>(ts.tv_nsec);
}

std::string sparkplug_edge_node_id(const SparkplugConfig& config) {
  if (!config.edge_node_id.empty()) return config.edge_node_id;
  char host[256] = {};
  ::gethostname(host, sizeof host - 1);
  std::string id = host[0] ? host : "lec6";
  for (char& c : id) {
    if (c == '/' || c == '+' || c == '#') c = '-';
  }
  return id;
}

SparkplugNode::Core::Core(asio::io_context& io_context, const AxisDirectory& d, Operations& o,
                          const SparkplugConfig& c, Log l)
    : io(io_context),
      directory(d),
      ops(o),
      config(c),
      log(std::move(l)),
      axes(d.axes()),
      history_on(d.history() != nullptr),
      timer(io_context),
      commands(axes.size()),
      health(axes.size()),
      health_text(axes.size()) {
  SessionConfig s;
  s.group_id = config.group_id;
  s.edge_node_id = sparkplug_edge_node_id(config);
  s.primary_host_id = config.primary_host_id;
  s.node_metrics = node_metrics(d.lines());
  for (const AxisRef& a : axes) {
    s.devices.push_back({a.name, axis_metrics(history_on)});
    woken.push_back(std::make_unique<std::atomic<bool>>(false));
    numbered.push_back(std::make_unique<std::atomic<int64_t>>(0));
    stops.push_back(std::make_unique<std::atomic<uint64_t>>(0));
  }
  command_offset = axis_metrics(history_on).size() - command_metrics().size();
  session = std::make_unique<EdgeSession>(std::move(s), read_bdseq(config.bdseq_file));
}

// A message the client could not queue (its window full, the connection
// just lost) leaves a gap in seq: the births follow at the next tick, so a
// host never waits on a number that will not come. A lost connection births
// anyway when it is back.
void SparkplugNode::Core::publish(const std::vector<Message>& out) {
  for (const Message& m : out) {
    if (client->publish(m.topic, m.payload, m.qos, m.retain)) {
      ++published;
    } else if (session->born()) {
      rebirth_due = true;
    }
  }
}

void SparkplugNode::Core::start() {
  const std::weak_ptr<Core> weak = weak_from_this();
  MqttClientOptions o;
  o.url = config.url();
  o.client_id = config.client_id.empty() ? "lec6-sparkplug-" + session->config().edge_node_id
                                         : config.client_id;
  o.username = config.username;
  o.password = config.password;
  o.ca_file = config.ca_file.string();
  o.cert_file = config.cert_file.string();
  o.key_file = config.key_file.string();
  o.thread_name = "lec-sparkplug";  // bench.mjs reads its CPU by this name
  o.keepalive_s = config.keepalive_s;
  o.reconnect_max_s = config.reconnect_max_s;
  o.will_topic = session->topic("NDEATH");
  o.will_retain = false;
  o.last_retain = false;
  // The primary host's STATE is retained, and only it: a retained command
  // (refused anyway) is not delivered again at every reconnect.
  if (!config.primary_host_id.empty())
    o.retained_filters = {fmt::format("{}/STATE/{}", kNamespace, config.primary_host_id)};
  o.will_update = [weak] {
    auto c = weak.lock();
    if (!c) return std::string();
    std::lock_guard lock(c->mutex);
    Message will = c->session->will();  // a new bdSeq for this CONNECT
    if (!write_bdseq(c->config.bdseq_file, c->session->bdseq()) && !c->bdseq_warned) {
      c->bdseq_warned = true;  // once: the connection goes on, a restart births with 0
      c->log(LogLevel::Warning,
             fmt::format("sparkplug: cannot write bdSeq to {}: a restart will not birth with the "
                         "next bdSeq",
                         c->config.bdseq_file.string()));
    }
    return will.payload;
  };
  MqttClientHandlers h;
  h.connected = [weak] {
    if (auto c = weak.lock()) c->on_connected();
  };
  h.disconnected = [weak](const std::string& why) {
    auto c = weak.lock();
    if (!c) return;
    {
      std::lock_guard lock(c->mutex);
      c->session->disconnected();
    }
    c->log(LogLevel::Warning, fmt::format("sparkplug: {}; retrying with back-off", why));
  };
  h.message = [weak](const MqttMessage& m) {
    if (auto c = weak.lock()) c->on_message(m);
  };
  client = std::make_unique<MqttClient>(std::move(o), std::move(h));

  // A flag, health or alarm change is sampled at once, not at the next tick.
  std::map<Line*, std::map<uint8_t, std::size_t>> lines;
  for (std::size_t i = 0; i < axes.size(); ++i) lines[axes[i].line][axes[i].id] = i;
  for (auto& entry : lines) {
    const std::map<uint8_t, std::size_t> ids = entry.second;
    entry.first->add_observer([weak, ids](const TelemetryEvent& e, const AxisSnapshot&) {
      if (!e.flags_changed && !e.online_changed && e.block != Block::Alarms) return;
      const auto it = ids.find(e.id);
      if (it == ids.end()) return;
      if (auto c = weak.lock()) c->wake(it->second);
    });
  }
  next_tick = next_node = std::chrono::steady_clock::now();
  tick();  // values first: the first NBIRTH has them
  client->start();
}

void SparkplugNode::Core::stop() {
  if (stopped.exchange(true)) return;
  timer.cancel();
  if (!client) return;
  std::optional<Message> bye;
  {
    std::lock_guard lock(mutex);
    bye = session->goodbye(unix_ms());
  }
  std::vector<std::pair<std::string, std::string>> last;
  if (bye) last.emplace_back(bye->topic, bye->payload);
  client->stop(last, kStopGrace);
  const uint64_t n = published.load();
  log(LogLevel::Info,
      fmt::format("sparkplug: NDEATH published, disconnected; {} messages published, the node's "
                  "sampling and encoding took {:.1f} ms of CPU ({:.0f} us per message)",
                  n, static_cast<double>(cpu_ns.load()) / 1e6,
                  n ? static_cast<double>(cpu_ns.load()) / 1e3 / static_cast<double>(n) : 0.0));
}

void SparkplugNode::Core::sample_axis(std::size_t i, uint64_t now_ms) {
  const AxisRef& a = axes[i];
  AxisNow now;
  now.telemetry = telemetry_json(a, a.line->snapshot(a.id));
  if (const auto r = ops.running(a)) now.running = r->op;
  now.last = ops.last_result(a.name);
  now.health = health[i];
  if (health[i]) now.health_text = &health_text[i];
  now.command = &commands[i];
  const bool online = now.telemetry.value("online", false) && now.telemetry.contains("flags");
  publish(session->device_values(i, online, axis_values(now, history_on), now_ms));
}

void SparkplugNode::Core::sample_node(uint64_t now_ms) {
  if (rebirth_due) {
    rebirth_due = false;
    publish(session->rebirth(now_ms));
  }
  std::vector<LineNow> lines;
  for (const LineConfig& lc : directory.lines()) {
    Line* line = directory.line(lc.name);
    if (!line) continue;
    lines.push_back({line->is_down() ? "down: " + line->down_reason() : "up", line->stats()});
  }
  publish(session->node_values(node_values(lines), now_ms));
}

// Every axis at the configured rate, the node's own metrics once a second.
// The history's health is read before the mutex: a DCMD never waits on SQLite.
void SparkplugNode::Core::tick() {
  const auto now = std::chrono::steady_clock::now();
  {
    CpuSpan cpu(cpu_ns);
    const bool node_due = now >= next_node;
    std::vector<std::optional<json>> fresh;
    if (node_due) {
      if (history::History* h = directory.history()) {
        for (const AxisRef& a : axes) fresh.push_back(h->health(a.name));
      }
    }
    std::lock_guard lock(mutex);
    const uint64_t ms = unix_ms();
    if (node_due) {
      if (!fresh.empty()) {
        health = std::move(fresh);
        for (std::size_t i = 0; i < health.size(); ++i)
          health_text[i] = health[i] ? health[i]->dump() : std::string();
      }
      sample_node(ms);
      next_node = now + std::chrono::seconds(1);
    } else if (rebirth_due) {
      rebirth_due = false;
      publish(session->rebirth(ms));
    }
    for (std::size_t i = 0; i < axes.size(); ++i) sample_axis(i, ms);
  }
  const auto period = std::chrono::duration_cast<std::chrono::steady_clock::duration>(
      std::chrono::duration<double>(1.0 / config.telemetry_hz));
  next_tick += period;
  if (next_tick < now) next_tick = now + period;
  timer.expires_at(next_tick);
  timer.async_wait([weak = weak_from_this()](const asio::error_code& ec) {
    if (ec) return;
    if (auto c = weak.lock(); c && !c->stopped) c->tick();
  });
}

void SparkplugNode::Core::wake(std::size_t i) {
  if (stopped || woken[i]->exchange(true)) return;
  asio::post(io, [weak = weak_from_this(), i] {
    auto c = weak.lock();
    if (!c) return;
    c->woken[i]->store(false);
    if (c->stopped) return;
    CpuSpan cpu(c->cpu_ns);
    std::lock_guard lock(c->mutex);
    c->sample_axis(i, unix_ms());
  });
}

// On the client's thread: subscriptions first, then the births (or the wait
// for the primary host's STATE).
void SparkplugNode::Core::on_connected() {
  if (stopped) return;
  std::lock_guard lock(mutex);
  rebirth_due = false;  // the births follow: a failure of the last connection is owed nothing
  ++connects;           // before any message of this connection is delivered
  client->subscribe(session->subscriptions());
  publish(session->connected(unix_ms()));
  log(LogLevel::Info,
      fmt::format(
          "sparkplug: connected to {}: {} with bdSeq {}{}", config.broker, session->topic("NBIRTH"),
          session->bdseq(),
          session->born() ? "" : fmt::format(", waiting for host {}", config.primary_host_id)));
}

// On the client's thread: a DCMD stop goes at once; everything else is
// handled on the event loop's thread, so the client's thread is free for the
// next message (a stop behind a burst of 2000 DCMDs waited for all of them).
void SparkplugNode::Core::on_message(const MqttMessage& m) {
  // Not even copied when it is too big for a command (session.hpp: kMaxCommandBytes).
  if (m.payload.size() > kMaxCommandBytes) {
    const auto axis = session->device_of_dcmd(m.topic);
    const std::string why = fmt::format(
        "a message of {} bytes on {} is refused unread (a "
        "command is at most {} bytes)",
        m.payload.size(), m.topic, kMaxCommandBytes);
    if (!axis) return log(LogLevel::Warning, "sparkplug: " + why);
    asio::post(io, [weak = weak_from_this(), i = *axis, why] {
      if (auto c = weak.lock(); c && !c->stopped) c->refuse(i, why);
    });
    return;
  }
  // A stop first, before the mutex a tick may hold (session.hpp:
  // stop_request), and while the node is stopping too (Operations takes stops then).
  if (const auto axis = session->stop_request(m.topic, m.payload, m.retain)) {
    stop_now(*axis);
    return;
  }
  if (stopped) return;
  std::vector<uint64_t> seen;
  for (const auto& n : stops) seen.push_back(n->load());
  asio::post(io,
             [weak = weak_from_this(), m, seen = std::move(seen), gen = connects.load()]() mutable {
               auto c = weak.lock();
               if (!c || c->stopped) return;
               // A message of an earlier MQTT session (the event loop was slow while the
               // client reconnected): its STATE or rebirth is not this session's.
               if (gen != c->connects.load()) {
                 c->log(LogLevel::Info,
                        "sparkplug: a message of the previous MQTT session dropped: " + m.topic);
                 return;
               }
               c->handle(m, std::move(seen));
             });
}

void SparkplugNode::Core::handle(const MqttMessage& m, std::vector<uint64_t> stops_seen) {
  CpuSpan cpu(cpu_ns);
  std::optional<DeviceCommand> cmd;
  std::optional<Refusal> refused;
  bool reconnect = false;
  {
    std::lock_guard lock(mutex);
    auto r = session->received(m.topic, m.payload, m.retain, unix_ms());
    publish(r.out);
    if (!r.note.empty()) log(LogLevel::Info, "sparkplug: " + r.note);
    cmd = std::move(r.command);
    refused = std::move(r.refused);
    reconnect = r.reconnect;
  }
  if (reconnect) client->reconnect();
  if (refused) refuse(refused->device, refused->why);
  if (!cmd) return;
  command(*cmd, stops_seen[cmd->device]);
}

// ---- the node ---------------------------------------------------------------------

SparkplugNode::SparkplugNode(asio::io_context& io, const AxisDirectory& directory, Operations& ops,
                             const SparkplugConfig& config, Log log)
    : core_(std::make_shared<Core>(io, directory, ops, config, std::move(log))) {}

SparkplugNode::~SparkplugNode() {
  core_->stop();
}

void SparkplugNode::start() {
  core_->start();
}

void SparkplugNode::stop() {
  core_->stop();
}

std::string SparkplugNode::describe() const {
  return fmt::format("sparkplug {} ({}/{}/{})", core_->config.broker, kNamespace,
                     core_->config.group_id, core_->session->config().edge_node_id);
}

}  // namespace lec6::serve
