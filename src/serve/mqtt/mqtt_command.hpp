#pragma once
// A command as it arrives on PREFIX/<line>/<axis>/cmd: a JSON object with
// the envelope (id, op, valid_for, issued_at) and the op's arguments in the
// same object (commands.hpp checks those).
//
//   {"id": "a17", "op": "move", "position_mm": 150, "valid_for": 5, "issued_at": 1767950000.2}
//
// Staleness (docs/mqtt.md): a command must never move an axis when it
// arrives late, after a broker outage or a client's own offline queue.
//   - with issued_at (Unix seconds): refused when older than valid_for, or
//     issued more than valid_for in the future (the clocks disagree);
//   - else with an MQTT 5 message expiry: the broker drops it once expired,
//     so it is fresh when it arrives; refused if its remaining expiry is
//     longer than valid_for (that promise is weaker than the command needs);
//   - else its age starts when the bridge receives it (the bridge keeps no
//     broker session, so nothing waits for it at the broker while it is away);
//   - a retained command is refused outright: its age cannot be known.
// valid_for defaults to mqtt.command_valid_for_s.
//
// Thread safety: pure functions.

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

#include "lec6/expected.hpp"

namespace lec6::serve {

// How a message reached the bridge.
struct Received {
  std::string_view payload;
  bool retained = false;
  std::optional<uint32_t> expiry_s;  // MQTT 5 message expiry left, when set
  double now_unix = 0;               // this box's clock, Unix seconds
};

struct MqttCommand {
  nlohmann::json id;   // as sent (a string or an integer), echoed in the result
  std::string id_key;  // the id as text, for deduplication
  std::string op;
  nlohmann::json payload;  // the whole object: parse_command reads its arguments
  double valid_for_s = 5;
  std::optional<double> issued_at;
};

// A refusal before anything reaches the line: HTTP-style status (400 bad
// payload, 408 stale), the JSON key at fault, and a message.
struct EnvelopeError {
  nlohmann::json id;  // null when the payload had none we could read
  int status = 400;
  std::string field;
  std::string message;
};

// How long a fresh command stays valid from now (s): valid_for less its age
// when it says when it was issued. A command that waits for a stop accepted
// before it is refused once this has passed (Command::start_by).
double seconds_valid(const MqttCommand& c, const Received& message);

// Reads the envelope (JSON object, id, op, valid_for, issued_at); the op's
// own arguments are not checked here.
Expected<MqttCommand, EnvelopeError> parse_envelope(const Received& message,
                                                    double default_valid_for_s);

// nullopt when `command` may run now; else why not (status 408, or 400 for
// a retained message).
std::optional<EnvelopeError> check_fresh(const MqttCommand& command, const Received& message);

}  // namespace lec6::serve
