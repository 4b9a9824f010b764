// The MQTT bridge: set-up, availability and telemetry. Commands are in
// mqtt_bridge_commands.cpp.

#include "mqtt/mqtt_bridge.hpp"

#include <fmt/format.h>
#include <unistd.h>

#include "history/history.hpp"
#include "lec6/lec/alarms.hpp"
#include "mqtt/mqtt_bridge_core.hpp"
#include "mqtt/mqtt_discovery.hpp"
#include "ops/views.hpp"

namespace lec6::serve {
namespace {

using nlohmann::json;

// How long stop() waits for the broker to take the "offline" messages.
constexpr Duration kStopGrace = std::chrono::seconds(2);

MqttClientOptions client_options(const MqttConfig& c, const MqttTopics& topics) {
  MqttClientOptions o;
  o.url = c.url();
  o.client_id = mqtt_client_id(c);
  o.username = c.username;
  o.password = c.password;
  o.ca_file = c.ca_file.string();
  o.cert_file = c.cert_file.string();
  o.key_file = c.key_file.string();
  o.keepalive_s = c.keepalive_s;
  o.reconnect_max_s = c.reconnect_max_s;
  o.will_topic = topics.status();
  o.will_payload = "offline";
  // The retained "offline" at a stop goes ahead of the DISCONNECT whatever
  // telemetry is still in flight (mqtt_client.hpp: last_qos).
  o.last_qos = 0;
  return o;
}

}  // namespace

double unix_now() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

std::string mqtt_client_id(const MqttConfig& config) {
  if (!config.client_id.empty()) return config.client_id;
  char host[256] = {};
  ::gethostname(host, sizeof host - 1);
  return fmt::format("lec6-{}", host[0] ? host : "box");
}

std::string mqtt_bridge_name(const MqttConfig& config) {
  return config.bridge.empty() ? mqtt_client_id(config) : config.bridge;
}

MqttBridge::Core::Core(asio::io_context& io_context, const AxisDirectory& directory, Operations& o,
                       const MqttConfig& c, Log l, MqttSessionFactory session)
    : io(io_context),
      ops(o),
      config(c),
      log(std::move(l)),
      topics(c.prefix, mqtt_bridge_name(c)),
      axes(directory.axes()),
      commands(axes.size()),
      make_session(std::move(session)),
      timer(io),
      history(directory.history()) {
  for (std::size_t i = 0; i < axes.size(); ++i) {
    const std::string& line = axes[i].line_config->name;
    const std::string& name = axes[i].name;
    auto a = std::make_unique<AxisOut>();
    a->state = topics.state(line, name);
    a->availability = topics.availability(line, name);
    a->alarm = topics.alarm(line, name);
    a->cmd = topics.cmd(line, name);
    a->result = topics.result(line, name);
    by_cmd_topic.emplace(a->cmd, i);
    out.push_back(std::move(a));
  }
}

// Handlers hold a weak reference: whatever outlives the bridge (a posted
// wake-up, an operation finishing late) finds it gone and does nothing.
void MqttBridge::Core::start() {
  const std::weak_ptr<Core> weak = weak_from_this();
  MqttClientHandlers h;
  h.connected = [weak] {
    if (auto c = weak.lock()) c->connected();
  };
  h.disconnected = [weak](const std::string& why) {
    if (auto c = weak.lock()) {
      c->log(LogLevel::Warning,
             fmt::format("mqtt: {}; retrying with back-off (the lines go on)", why));
    }
  };
  h.message = [weak](const MqttMessage& m) {
    if (auto c = weak.lock()) c->command(m);
  };
  if (make_session) {
    client = make_session(client_options(config, topics), std::move(h));
  } else {
    client = std::make_unique<MqttClient>(client_options(config, topics), std::move(h));
  }

  // One observer per line, waking the axes whose flags, health or alarms changed.
  std::map<Line*, std::map<uint8_t, std::size_t>> lines;
  for (std::size_t i = 0; i < axes.size(); ++i) lines[axes[i].line][axes[i].id] = i;
  for (auto& entry : lines) {  // not a structured binding: clang 14 cannot capture one
    const std::map<uint8_t, std::size_t> ids = entry.second;
    entry.first->add_observer([weak, ids](const TelemetryEvent& e, const AxisSnapshot&) {
      if (!e.flags_changed && !e.online_changed && e.block != Block::Alarms) return;
      const auto it = ids.find(e.id);
      if (it == ids.end()) return;
      if (auto c = weak.lock()) c->wake(it->second);
    });
  }
  // issue 26: each motion record to .../history (QoS 1), the axis' health
  // retained to .../health, from whichever thread recorded it.
  if (history) {
    std::map<std::string, std::string> line_of;
    for (const AxisRef& a : axes) line_of[a.name] = a.line_config->name;
    history->add_listener(
        [weak, line_of](const std::string& axis, std::string_view kind, const json& j) {
          if (kind != "history" && kind != "health") return;
          const auto it = line_of.find(axis);
          auto c = weak.lock();
          if (!c || c->stopped || it == line_of.end()) return;
          c->client->publish(c->topics.axis(it->second, axis, kind), j.dump(), 1, kind == "health");
        });
  }
  client->start();
  next_tick = std::chrono::steady_clock::now();
  tick();
}

void MqttBridge::Core::stop() {
  if (stopped.exchange(true)) return;
  timer.cancel();
  if (!client) return;
  std::vector<std::pair<std::string, std::string>> last{{topics.status(), "offline"}};
  for (const auto& a : out) last.emplace_back(a->availability, "offline");
  client->stop(last, kStopGrace);
  log(LogLevel::Info, "mqtt: offline published, disconnected");
}

// On the client's thread: subscribe, and have the event loop republish every
// retained topic (the broker may have restarted empty), then say online: a
// subscriber that waits for "online" finds the retained state already there.
void MqttBridge::Core::connected() {
  std::vector<std::string> filters;
  for (const auto& a : out) filters.push_back(a->cmd);
  client->subscribe(filters);
  log(LogLevel::Info, fmt::format("mqtt: connected to {} as {}; {}/... online", config.broker,
                                  mqtt_client_id(config), topics.prefix()));
  asio::post(io, [weak = weak_from_this()] {
    auto c = weak.lock();
    if (!c || c->stopped) return;
    c->republish();
    c->client->publish(c->topics.status(), "online", 1, true);
  });
}

void MqttBridge::Core::republish() {
  for (std::size_t i = 0; i < axes.size(); ++i) publish_axis(i, true);
  if (history) {  // issue 26
    for (const AxisRef& a : axes) {
      client->publish(topics.axis(a.line_config->name, a.name, "health"),
                      history->health(a.name).dump(), 1, true);
    }
  }
  if (!config.home_assistant) return;
  for (const AxisRef& a : axes) {
    for (const auto& p : home_assistant_discovery(topics, a.line_config->name, a.name, a.id)) {
      client->publish(p.topic, p.payload.dump(), 1, true);
    }
  }
}

// Every axis at the configured rate, on a fixed schedule (no drift); a
// schedule that fell behind (a stalled loop) restarts from now.
void MqttBridge::Core::tick() {
  for (std::size_t i = 0; i < axes.size(); ++i) publish_axis(i, false);
  const auto period = std::chrono::duration_cast<std::chrono::steady_clock::duration>(
      std::chrono::duration<double>(1.0 / config.telemetry_hz));
  const auto now = std::chrono::steady_clock::now();
  next_tick += period;
  if (next_tick < now) next_tick = now + period;
  timer.expires_at(next_tick);
  timer.async_wait([weak = weak_from_this()](const asio::error_code& ec) {
    if (ec) return;
    if (auto c = weak.lock(); c && !c->stopped) c->tick();
  });
}

// From a line's thread: at most one wake-up per axis waits on the event loop.
void MqttBridge::Core::wake(std::size_t i) {
  if (stopped || out[i]->wake.exchange(true)) return;
  asio::post(io, [weak = weak_from_this(), i] {
    auto c = weak.lock();
    if (!c) return;
    c->out[i]->wake = false;
    if (!c->stopped) c->publish_axis(i, false);
  });
}

void MqttBridge::Core::publish_axis(std::size_t i, bool force) {
  const AxisRef& a = axes[i];
  AxisOut& o = *out[i];
  const AxisSnapshot s = a.line->snapshot(a.id);
  json j = telemetry_json(a, s);
  const double now = unix_now();
  if (s.state_at != TimePoint{}) {
    j["at"] = now - to_seconds(a.line->clock().now() - s.state_at);  // when it was read
  }
  const bool connected = client->connected();
  if (connected) client->publish(o.state, j.dump(), 0, true);
  const bool online = j.value("online", false);
  if (connected && (force || o.online != online)) {
    if (client->publish(o.availability, online ? "online" : "offline", 1, true)) o.online = online;
  }
  alarm_events(i, j["alarms"], now);
}

void MqttBridge::Core::alarm_events(std::size_t i, const json& alarms, double at) {
  AxisOut& o = *out[i];
  std::set<int> active;
  for (const auto& a : alarms) active.insert(a.value("code", 0));
  const AxisRef& axis = axes[i];
  auto event = [&](const char* what, int code) {
    json e{{"event", what},
           {"code", code},
           {"meaning", std::string(lec::alarm_meaning(static_cast<uint8_t>(code)))},
           {"resettable", lec::alarm_resettable(static_cast<uint8_t>(code))},
           {"axis", axis.name},
           {"line", axis.line_config->name},
           {"at", at}};
    client->publish(o.alarm, e.dump(), 1, false);
  };
  for (int code : active) {
    if (!o.alarms.contains(code)) event("raised", code);
  }
  for (int code : o.alarms) {
    if (!active.contains(code)) event("cleared", code);
  }
  o.alarms = std::move(active);
}

// ---- the bridge -------------------------------------------------------------------

MqttBridge::MqttBridge(asio::io_context& io, const AxisDirectory& directory, Operations& ops,
                       const MqttConfig& config, Log log, MqttSessionFactory session)
    : core_(
          std::make_shared<Core>(io, directory, ops, config, std::move(log), std::move(session))) {}

MqttBridge::~MqttBridge() {
  core_->stop();
}

void MqttBridge::start() {
  core_->start();
}

void MqttBridge::stop() {
  core_->stop();
}

std::string MqttBridge::describe() const {
  return fmt::format("{} (bridge {}, prefix {})", core_->config.broker, core_->topics.bridge(),
                     core_->topics.prefix());
}

}  // namespace lec6::serve
