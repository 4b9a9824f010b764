// The MQTT bridge's commands: envelope, deduplication, staleness, the op's
// arguments, then Operations; results to .../result and the response topic.

#include <fmt/format.h>

#include "mqtt/mqtt_bridge_core.hpp"
#include "ops/commands.hpp"

namespace lec6::serve {
namespace {

using nlohmann::json;

const SteadyClock kClock;

}  // namespace

// On the client's thread. Nothing here waits: a command that may run is
// handed to Operations, whose completion publishes the result.
void MqttBridge::Core::command(const MqttMessage& m) {
  const auto it = by_cmd_topic.find(m.topic);
  if (it == by_cmd_topic.end() || stopped) return;
  const std::size_t i = it->second;
  if (m.retain && m.payload.empty()) return;  // a retained command being deleted
  std::vector<ReplyTo> to;
  if (m.response_topic) to.push_back({*m.response_topic, m.correlation.value_or("")});
  if (m.retain) {
    // Delete it from the broker too: any later subscriber would get it.
    client->publish(m.topic, "", 1, true);
  }
  const Received received{m.payload, m.retain, m.expiry_s, unix_now()};
  auto envelope = parse_envelope(received, config.command_valid_for_s);
  if (!envelope) return refuse(i, envelope.error(), to);
  const MqttCommand& c = *envelope;

  CommandLog::Lookup seen;
  std::optional<EnvelopeError> why;
  std::optional<Command> cmd;
  {
    std::lock_guard lock(commands_mutex);
    // A retained copy is refused whatever its id: never a result lookup.
    if (!received.retained) seen = commands[i].find(c.id_key, kClock.now(), to);
    if (seen.seen == CommandLog::Seen::New) {
      auto parsed = parse_command(c.op, c.payload);
      if (!parsed) {
        why = EnvelopeError{c.id, 400, parsed.error().field, parsed.error().message};
      } else if (!stops_motion(*parsed) || received.retained) {
        // Freshness exists so that a late command never moves an axis: a
        // stop, hold or reset is never refused by it (issue 31 rule 5). A
        // retained copy is refused all the same: it would act again at every
        // restart.
        why = check_fresh(c, received);
        parsed->start_by =
            kClock.now() + to_duration(FractionalSeconds(seconds_valid(c, received)));
      }
      if (!why) {
        cmd = std::move(*parsed);
        commands[i].start(c.id_key, kClock.now(), to);
      }
    }
  }
  if (seen.seen == CommandLog::Seen::Done) return reply(i, seen.result, to);
  if (seen.seen == CommandLog::Seen::Running) return;  // its result comes when it ends
  if (why) {
    if (why->status == 408 || why->field == "retain") {
      log(LogLevel::Warning,
          fmt::format("mqtt: command {} for {} refused: {}", c.id_key, axes[i].name, why->message));
    }
    return refuse(i, *why, to);
  }
  ops.run(axes[i], std::move(*cmd), fmt::format("mqtt id {}", c.id_key),
          [weak = weak_from_this(), i, id = c.id, key = c.id_key](OpResult result) {
            if (auto self = weak.lock()) self->finished(i, id, key, result);
          });
}

void MqttBridge::Core::finished(std::size_t i, const json& id, const std::string& key,
                                const OpResult& result) {
  json body = result.body;
  body["id"] = id;
  body["status"] = result.status;
  const std::string payload = body.dump();
  std::vector<ReplyTo> to;
  {
    std::lock_guard lock(commands_mutex);
    to = commands[i].finish(key, payload, kClock.now());
  }
  reply(i, payload, to);
}

void MqttBridge::Core::refuse(std::size_t i, const EnvelopeError& e,
                              const std::vector<ReplyTo>& to) {
  json body{{"id", e.id}, {"ok", false}, {"status", e.status}, {"error", e.message}};
  if (!e.field.empty()) body["field"] = e.field;
  reply(i, body.dump(), to);
}

void MqttBridge::Core::reply(std::size_t i, const std::string& payload,
                             const std::vector<ReplyTo>& to) {
  client->publish(out[i]->result, payload, 1, false);
  for (const ReplyTo& r : to) client->publish(r.topic, payload, 1, false, &r);
}

}  // namespace lec6::serve
