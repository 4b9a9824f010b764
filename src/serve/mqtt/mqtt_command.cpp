#include "mqtt/mqtt_command.hpp"

#include <fmt/format.h>

#include <cmath>

namespace lec6::serve {
namespace {

using nlohmann::json;

constexpr std::size_t kMaxIdLength = 128;
constexpr double kMaxValidForS = 3600;

Unexpected<EnvelopeError> refuse(json id, std::string field, std::string message) {
  return unexpected(EnvelopeError{std::move(id), 400, std::move(field), std::move(message)});
}

}  // namespace

Expected<MqttCommand, EnvelopeError> parse_envelope(const Received& message,
                                                    double default_valid_for_s) {
  if (message.payload.empty()) {
    return refuse(nullptr, "", "the command is empty: expected a JSON object with id and op");
  }
  json j = json::parse(message.payload, nullptr, false);
  if (j.is_discarded()) return refuse(nullptr, "", "the command is not valid JSON");
  if (!j.is_object()) return refuse(nullptr, "", "the command must be a JSON object");
  MqttCommand c;
  if (!j.contains("id")) {
    return refuse(nullptr, "id", "every command needs an id (a string or an integer, unique)");
  }
  const json& id = j["id"];
  if (id.is_string()) {
    c.id_key = id.get<std::string>();
    if (c.id_key.empty() || c.id_key.size() > kMaxIdLength) {
      return refuse(id, "id", fmt::format("id must be 1 to {} characters", kMaxIdLength));
    }
  } else if (id.is_number_integer() || id.is_number_unsigned()) {
    c.id_key = id.dump();
  } else {
    return refuse(nullptr, "id", "id must be a string or an integer");
  }
  c.id = id;
  if (!j.contains("op")) return refuse(c.id, "op", "every command needs an op (move, home, …)");
  if (!j["op"].is_string()) return refuse(c.id, "op", "op must be a string (move, home, …)");
  c.op = j["op"].get<std::string>();
  c.valid_for_s = default_valid_for_s;
  if (j.contains("valid_for")) {
    const json& v = j["valid_for"];
    if (!v.is_number() || !std::isfinite(v.get<double>()) || v.get<double>() <= 0 ||
        v.get<double>() > kMaxValidForS) {
      return refuse(c.id, "valid_for",
                    fmt::format("valid_for must be a number of seconds, above 0 and at most {}",
                                kMaxValidForS));
    }
    c.valid_for_s = v.get<double>();
  }
  if (j.contains("issued_at")) {
    const json& v = j["issued_at"];
    if (!v.is_number() || !std::isfinite(v.get<double>()) || v.get<double>() < 0) {
      return refuse(c.id, "issued_at", "issued_at must be a time in Unix seconds (a number)");
    }
    c.issued_at = v.get<double>();
  }
  c.payload = std::move(j);
  return c;
}

double seconds_valid(const MqttCommand& c, const Received& message) {
  const double age = c.issued_at ? std::max(0.0, message.now_unix - *c.issued_at) : 0.0;
  return c.valid_for_s - age;
}

std::optional<EnvelopeError> check_fresh(const MqttCommand& c, const Received& message) {
  if (message.retained) {
    return EnvelopeError{c.id, 400, "retain",
                         "a retained command is refused: its age cannot be known (publish "
                         "commands with retain off)"};
  }
  if (c.issued_at) {
    const double age = message.now_unix - *c.issued_at;
    if (age > c.valid_for_s) {
      return EnvelopeError{c.id, 408, "issued_at",
                           fmt::format("the command is stale: issued {:.1f} s ago, valid for "
                                       "{:g} s; refused so that a late command never moves an "
                                       "axis",
                                       age, c.valid_for_s)};
    }
    if (-age > c.valid_for_s) {
      return EnvelopeError{c.id, 408, "issued_at",
                           fmt::format("issued_at is {:.1f} s in the future: the sender's clock "
                                       "and this box's disagree (keep both on NTP)",
                                       -age)};
    }
    return std::nullopt;
  }
  if (message.expiry_s && *message.expiry_s > c.valid_for_s) {
    return EnvelopeError{c.id, 408, "message_expiry",
                         fmt::format("the message expires in {} s, later than valid_for {:g} s: "
                                     "the broker could deliver it too late (set issued_at, or an "
                                     "expiry within valid_for)",
                                     *message.expiry_s, c.valid_for_s)};
  }
  return std::nullopt;
}

}  // namespace lec6::serve
