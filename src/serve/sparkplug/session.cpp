#include "sparkplug/session.hpp"

#include <fmt/format.h>

#include <nlohmann/json.hpp>

namespace lec6::serve::sparkplug {
namespace {

bool is_integer(DataType t) {
  switch (t) {
    case DataType::Int8:
    case DataType::Int16:
    case DataType::Int32:
    case DataType::Int64:
    case DataType::UInt8:
    case DataType::UInt16:
    case DataType::UInt32:
    case DataType::UInt64:
    case DataType::DateTime:
      return true;
    default:
      return false;
  }
}

bool is_text(DataType t) {
  return t == DataType::String || t == DataType::Text;
}

// Two types a host may use for the same metric (Int32 for Int64, Text for String).
bool same_kind(DataType a, DataType b) {
  if (a == b) return true;
  if (is_integer(a) && is_integer(b)) return true;
  if (is_text(a) && is_text(b)) return true;
  return (a == DataType::Float || a == DataType::Double) &&
         (b == DataType::Float || b == DataType::Double);
}

}  // namespace

bool compatible(DataType type, const Value& v) {
  if (type == DataType::Boolean) return std::holds_alternative<bool>(v);
  if (is_integer(type)) {
    return std::holds_alternative<int64_t>(v) || std::holds_alternative<uint64_t>(v);
  }
  if (type == DataType::Float || type == DataType::Double) {
    return std::holds_alternative<double>(v) || std::holds_alternative<int64_t>(v) ||
           std::holds_alternative<uint64_t>(v);
  }
  if (is_text(type)) return std::holds_alternative<std::string>(v);
  return false;
}

EdgeSession::EdgeSession(SessionConfig config, std::optional<uint8_t> last_bdseq)
    : config_(std::move(config)), last_bdseq_(last_bdseq) {
  uint64_t next = config_.node_metrics.size() + 1;
  for (const DeviceDef& d : config_.devices) {
    alias_base_.push_back(next);
    next += d.metrics.size();
    Device dev;
    dev.now.resize(d.metrics.size());
    devices_.push_back(std::move(dev));
  }
  node_now_.resize(config_.node_metrics.size());
}

std::string EdgeSession::topic(std::string_view verb, const std::string* device) const {
  std::string t =
      fmt::format("{}/{}/{}/{}", kNamespace, config_.group_id, verb, config_.edge_node_id);
  if (device) t += "/" + *device;
  return t;
}

std::vector<std::string> EdgeSession::subscriptions() const {
  std::vector<std::string> s{topic("NCMD"), topic("DCMD") + "/+"};
  if (!config_.primary_host_id.empty()) {
    s.push_back(fmt::format("{}/STATE/{}", kNamespace, config_.primary_host_id));
  }
  return s;
}

uint64_t EdgeSession::alias_of(std::size_t device, std::size_t metric) const {
  return alias_base_.at(device) + metric;
}

uint64_t EdgeSession::next_seq() {
  const uint64_t s = seq_;
  seq_ = static_cast<uint8_t>(seq_ + 1);  // 255 -> 0
  return s;
}

Message EdgeSession::ndeath(std::optional<uint64_t> now_ms) const {
  Payload p;
  p.timestamp_ms = now_ms;
  Metric bd;
  bd.name = std::string(kBdSeq);
  bd.datatype = DataType::Int64;
  bd.value = static_cast<int64_t>(bdseq_);
  bd.timestamp_ms = now_ms;
  p.metrics.push_back(std::move(bd));
  return {topic("NDEATH"), encode(p), 1, false};
}

Message EdgeSession::will() {
  bdseq_ = last_bdseq_ ? static_cast<uint8_t>(*last_bdseq_ + 1) : 0;
  last_bdseq_ = bdseq_;
  death_said_ = false;
  // The broker publishes it at a moment nobody can number: no seq, no timestamp.
  return ndeath(std::nullopt);
}

std::vector<Message> EdgeSession::connected(uint64_t now_ms) {
  connected_ = true;
  born_ = false;
  host_state_ms_.reset();
  if (!config_.primary_host_id.empty()) return {};  // wait for STATE online
  return births(now_ms);
}

void EdgeSession::disconnected() {
  connected_ = false;
  born_ = false;
  for (Device& d : devices_) d.born = false;
}

std::vector<Message> EdgeSession::births(uint64_t now_ms) {
  std::vector<Message> out;
  seq_ = 0;
  Payload p;
  p.timestamp_ms = now_ms;
  p.seq = next_seq();
  auto add = [&](std::string name, std::optional<uint64_t> alias, DataType t, Value v) {
    Metric m;
    m.name = std::move(name);
    m.alias = alias;
    m.timestamp_ms = now_ms;
    m.datatype = t;
    m.value = std::move(v);
    p.metrics.push_back(std::move(m));
  };
  add(std::string(kBdSeq), std::nullopt, DataType::Int64, static_cast<int64_t>(bdseq_));
  add(std::string(kRebirth), std::nullopt, DataType::Boolean, false);
  for (std::size_t i = 0; i < config_.node_metrics.size(); ++i) {
    add(config_.node_metrics[i].name, alias_of_node(i), config_.node_metrics[i].type, node_now_[i]);
  }
  node_sent_ = node_now_;
  out.push_back({topic("NBIRTH"), encode(p), 0, false});
  born_ = true;
  for (std::size_t d = 0; d < devices_.size(); ++d) {
    devices_[d].born = false;
    if (devices_[d].online) out.push_back(dbirth(d, now_ms));
  }
  return out;
}

Message EdgeSession::dbirth(std::size_t d, uint64_t now_ms) {
  Device& dev = devices_[d];
  const DeviceDef& def = config_.devices[d];
  Payload p;
  p.timestamp_ms = now_ms;
  p.seq = next_seq();
  for (std::size_t i = 0; i < def.metrics.size(); ++i) {
    Metric m;
    m.name = def.metrics[i].name;
    m.alias = alias_of(d, i);
    m.timestamp_ms = now_ms;
    m.datatype = def.metrics[i].type;
    m.value = dev.now[i];
    p.metrics.push_back(std::move(m));
  }
  dev.sent = dev.now;
  dev.born = true;
  return {topic("DBIRTH", &def.id), encode(p), 0, false};
}

std::vector<Message> EdgeSession::node_values(std::vector<Value> values, uint64_t now_ms) {
  values.resize(config_.node_metrics.size());
  node_now_ = std::move(values);
  if (!born_) return {};
  Payload p;
  for (std::size_t i = 0; i < node_now_.size(); ++i) {
    if (node_now_[i] == node_sent_[i]) continue;
    Metric m;
    m.alias = alias_of_node(i);
    m.timestamp_ms = now_ms;
    m.datatype = config_.node_metrics[i].type;
    m.value = node_now_[i];
    p.metrics.push_back(std::move(m));
  }
  if (p.metrics.empty()) return {};
  node_sent_ = node_now_;
  p.timestamp_ms = now_ms;
  p.seq = next_seq();
  return {{topic("NDATA"), encode(p), 0, false}};
}

std::vector<Message> EdgeSession::device_values(std::size_t d, bool online,
                                                std::vector<Value> values, uint64_t now_ms) {
  Device& dev = devices_.at(d);
  const DeviceDef& def = config_.devices[d];
  values.resize(def.metrics.size());
  dev.now = std::move(values);
  dev.online = online;
  if (!born_) return {};
  if (!online) {
    if (!dev.born) return {};
    dev.born = false;
    Payload p;
    p.timestamp_ms = now_ms;
    p.seq = next_seq();
    return {{topic("DDEATH", &def.id), encode(p), 0, false}};
  }
  if (!dev.born) return {dbirth(d, now_ms)};
  Payload p;
  for (std::size_t i = 0; i < dev.now.size(); ++i) {
    if (dev.now[i] == dev.sent[i]) continue;
    Metric m;
    m.alias = alias_of(d, i);
    m.timestamp_ms = now_ms;
    m.datatype = def.metrics[i].type;
    m.value = dev.now[i];
    p.metrics.push_back(std::move(m));
  }
  if (p.metrics.empty()) return {};
  dev.sent = dev.now;
  p.timestamp_ms = now_ms;
  p.seq = next_seq();
  return {{topic("DDATA", &def.id), encode(p), 0, false}};
}

std::optional<Message> EdgeSession::goodbye(uint64_t now_ms) {
  born_ = false;
  // Nothing births after the node's own NDEATH until the next connect (a
  // STATE online processed before the DISCONNECT must not birth again).
  connected_ = false;
  for (Device& d : devices_) d.born = false;
  if (death_said_) return std::nullopt;
  death_said_ = true;
  return ndeath(now_ms);
}

EdgeSession::Reaction EdgeSession::received(std::string_view t, std::string_view payload,
                                            bool retained, uint64_t now_ms) {
  if (!config_.primary_host_id.empty() &&
      t == fmt::format("{}/STATE/{}", kNamespace, config_.primary_host_id)) {
    return state(payload, now_ms);
  }
  if (t == topic("NCMD")) return ncmd(payload, retained, now_ms);
  if (t.starts_with(topic("DCMD") + "/")) {
    if (const auto d = device_of_dcmd(t)) return dcmd(*d, payload, retained);
    Reaction r;
    r.note =
        fmt::format("DCMD for an unknown device '{}' ignored", t.substr(topic("DCMD").size() + 1));
    return r;
  }
  Reaction r;
  r.note = fmt::format("message on {} ignored", t);
  return r;
}

EdgeSession::Reaction EdgeSession::state(std::string_view payload, uint64_t now_ms) {
  Reaction r;
  const auto j = nlohmann::json::parse(payload, nullptr, false);
  if (!j.is_object() || !j.contains("online") || !j["online"].is_boolean()) {
    r.note = fmt::format("STATE of host '{}' ignored: not {{\"online\": ..., \"timestamp\": ...}}",
                         config_.primary_host_id);
    return r;
  }
  const bool online = j["online"].get<bool>();
  // Anyone may publish on the STATE topic: a timestamp that is not an
  // unsigned number is a note, never an exception on the MQTT thread.
  const auto stamp = j.find("timestamp");
  if (stamp != j.end() && !stamp->is_number_unsigned()) {
    r.note = fmt::format("STATE of host '{}' ignored: its timestamp is not a number of ms",
                         config_.primary_host_id);
    return r;
  }
  const uint64_t ts = stamp == j.end() ? 0 : stamp->get<uint64_t>();
  // tck-id-operational-behavior-edge-node-termination-host-offline-timestamp
  if (host_state_ms_ && ts < *host_state_ms_) {
    r.note =
        fmt::format("STATE of host '{}' ignored: older than the last one", config_.primary_host_id);
    return r;
  }
  host_state_ms_ = ts;
  if (online) {
    if (connected_ && !born_) r.out = births(now_ms);
    return r;
  }
  if (born_) {
    if (auto bye = goodbye(now_ms)) r.out.push_back(std::move(*bye));
    r.reconnect = true;
    r.note =
        fmt::format("primary host '{}' is offline: NDEATH, reconnecting", config_.primary_host_id);
  }
  return r;
}

EdgeSession::Reaction EdgeSession::ncmd(std::string_view payload, bool retained, uint64_t now_ms) {
  Reaction r;
  if (retained) {
    r.note = "a retained NCMD ignored (its age cannot be known)";
    return r;
  }
  if (payload.size() > kMaxCommandBytes) {
    r.note = fmt::format("an NCMD of {} bytes ignored unread", payload.size());
    return r;
  }
  auto p = decode(payload);
  if (!p) {
    r.note = "NCMD ignored: " + p.error();
    return r;
  }
  for (const Metric& m : p->metrics) {
    if (m.name == kRebirth && std::holds_alternative<bool>(m.value) && std::get<bool>(m.value)) {
      r.out = rebirth(now_ms);  // same bdSeq: the MQTT session goes on
      r.note = "rebirth requested";
      return r;
    }
  }
  r.note = "NCMD without Node Control/Rebirth = true ignored";
  return r;
}

EdgeSession::Reaction EdgeSession::dcmd(std::size_t d, std::string_view payload, bool retained) {
  Reaction r;
  const DeviceDef& def = config_.devices[d];
  auto refuse = [&](std::string why) {
    r.refused = Refusal{d, std::move(why)};
    return r;
  };
  if (retained) return refuse("a retained DCMD is refused: its age cannot be known");
  if (payload.size() > kMaxCommandBytes) {
    return refuse(fmt::format("a DCMD of {} bytes is refused unread (a command is at most {})",
                              payload.size(), kMaxCommandBytes));
  }
  DeviceCommand c{d, {}};
  // A stop goes whatever else the DCMD holds, a bad metric (even one that
  // is not well-formed protobuf) included: the one stop rule, a stop never
  // waits for, nor falls with, anything else.
  std::optional<Metric> stop;
  visit_metrics_leniently(payload, [&](Metric&& m) {
    if (is_stop(d, m)) stop = std::move(m);
    return !stop;
  });
  if (stop) {
    c.writes.push_back({*metric_index(d, *stop), stop->value});
    r.command = std::move(c);
    return r;
  }
  auto p = decode(payload);
  if (!p) return refuse(p.error());
  if (p->metrics.empty()) return refuse("a DCMD without metrics");
  if (!born_) {
    return refuse(
        "the edge node is not born (not connected, or waiting for the primary host): only a "
        "stop is taken");
  }
  for (const Metric& m : p->metrics) {
    const std::optional<std::size_t> index = metric_index(d, m);
    const std::string label = m.name    ? "'" + *m.name + "'"
                              : m.alias ? fmt::format("alias {}", *m.alias)
                                        : std::string("a metric without name or alias");
    if (!index) return refuse(fmt::format("unknown metric {} (not in {}'s DBIRTH)", label, def.id));
    const MetricDef& md = def.metrics[*index];
    if (!md.writable) return refuse(fmt::format("'{}' is read-only", md.name));
    if (m.datatype && !same_kind(*m.datatype, md.type)) {
      return refuse(
          fmt::format("'{}' is {}, not {}", md.name, type_name(md.type), type_name(*m.datatype)));
    }
    if (std::holds_alternative<std::monostate>(m.value)) {
      return refuse(fmt::format("'{}' has no value", md.name));
    }
    if (!compatible(md.type, m.value)) {
      return refuse(fmt::format("'{}' is {}: the value sent is of another type", md.name,
                                type_name(md.type)));
    }
    c.writes.push_back({*index, m.value});
  }
  r.command = std::move(c);
  return r;
}

std::optional<std::size_t> EdgeSession::device_of_dcmd(std::string_view t) const {
  const std::string prefix = topic("DCMD") + "/";
  if (!t.starts_with(prefix)) return std::nullopt;
  const std::string_view id = t.substr(prefix.size());
  for (std::size_t d = 0; d < config_.devices.size(); ++d) {
    if (config_.devices[d].id == id) return d;
  }
  return std::nullopt;
}

std::optional<std::size_t> EdgeSession::metric_index(std::size_t d, const Metric& m) const {
  const DeviceDef& def = config_.devices[d];
  if (m.alias) {
    const uint64_t base = alias_base_[d];
    if (*m.alias >= base && *m.alias < base + def.metrics.size()) return *m.alias - base;
    return std::nullopt;
  }
  if (m.name) {
    for (std::size_t i = 0; i < def.metrics.size(); ++i) {
      if (def.metrics[i].name == *m.name) return i;
    }
  }
  return std::nullopt;
}

bool EdgeSession::is_stop(std::size_t d, const Metric& m) const {
  const auto index = metric_index(d, m);
  const auto* on = std::get_if<bool>(&m.value);
  return index && config_.devices[d].metrics[*index].name == "Command/Stop" && on && *on;
}

std::optional<std::size_t> EdgeSession::stop_request(std::string_view t, std::string_view payload,
                                                     bool retained) const {
  if (retained || payload.size() > kMaxCommandBytes) return std::nullopt;
  const auto d = device_of_dcmd(t);
  if (!d) return std::nullopt;
  // At the first stop: nothing more of the DCMD is read (nor kept).
  bool found = false;
  visit_metrics_leniently(payload, [&](Metric&& m) {
    found = is_stop(*d, m);
    return !found;
  });
  return found ? d : std::nullopt;
}

std::vector<Message> EdgeSession::rebirth(uint64_t now_ms) {
  if (!born_) return {};
  return births(now_ms);
}

}  // namespace lec6::serve::sparkplug
