#pragma once
// What lec serve does with one request from a TCP master (Modbus TCP or RTU
// over TCP), decided in one place for both listeners:
//
//   - an undecodable PDU: exception 01 (unknown function) or 03;
//   - unit id 0 (broadcast): a write to every controller of the line when the
//     line allows broadcasts, else exception 0A;
//   - a unit that is not an axis of the line: exception 0A;
//   - a write on a read-only listener: exception 01;
//   - what the memory map refuses (lec::check_request): the controller's own
//     exception code, answered without using the line;
//   - FC06 (write one register), when the listener accepts it: the same
//     register written by a one-register FC10, under the same checks and the
//     same stop rule (a HOLD written to D90C1 by FC06 is a stop), answered
//     with FC06's echo (tcp_reply_pdu); else exception 01, as the controller;
//   - anything else: a Job at client priority — reads may be answered from
//     the telemetry cache and are retried on a lost reply; writes never are.
//
// And the other way: what a failed job becomes for the master (gateway
// exceptions 0A, 0B and 06, per the Modbus application protocol).
//
// Thread safety: pure functions.

#include <cstdint>
#include <optional>
#include <set>
#include <span>
#include <variant>
#include <vector>

#include "lec6/modbus/pdu.hpp"
#include "line/scheduler.hpp"

namespace lec6::serve {

struct GatewayPolicy {
  std::set<uint8_t> units;  // the axes' IDs on this line
  bool allow_broadcast = false;
  bool read_only = false;
  Duration cache_max_age{};
  int read_retries = 2;
  // FC06 (write one register) accepted as the equivalent one-register FC10
  // and answered with FC06's echo (ListenerConfig::fc06).
  bool accept_fc06 = true;
};

// Either an answer to give at once, or the request to put on the line.
struct LocalAnswer {
  modbus::Response pdu;  // an ExceptionResponse
};
struct LineRequest {
  modbus::RequestFrame frame;
  Duration max_cache_age{};
  int attempts = 1;
  // A PLC's stop is a stop too: RESET, HOLD, SVON off… go at Emergency
  // (priority_of, the one rule), everything else at Command.
  Priority priority = Priority::Command;
  // An FC06 written as FC10: its answer is this echo (the request PDU), not
  // the FC10 reply.
  std::optional<modbus::Bytes> fc06_echo;
};
using GatewayDecision = std::variant<LocalAnswer, LineRequest>;

GatewayDecision decide(const GatewayPolicy& policy, uint8_t unit, std::span<const uint8_t> pdu);

// The reply a Modbus TCP master gets for a finished job; nullopt: none
// (cancelled: the master is gone).
std::optional<modbus::Response> tcp_reply(const modbus::RequestFrame& frame, const JobResult& r);
// The PDU a master gets for a finished LineRequest: FC06's echo when the
// request was an FC06 and the FC10 succeeded, else tcp_reply's, encoded.
std::optional<modbus::Bytes> tcp_reply_pdu(const LineRequest& request, const JobResult& r);

}  // namespace lec6::serve
