#include "modbus_tcp/gateway.hpp"

#include "lec6/lec/memory_map.hpp"
#include "line/line_master.hpp"

namespace lec6::serve {
namespace {

using modbus::ExceptionCode;

LocalAnswer exception(uint8_t raw_function, ExceptionCode code) {
  const auto fc = static_cast<modbus::FunctionCode>(raw_function & 0x7F);
  return LocalAnswer{modbus::ExceptionResponse{fc, raw_function, code}};
}

// What a controller would have answered to a write: a broadcast gets no reply
// on the line, but a TCP master is owed one.
modbus::Response write_reply(const modbus::Request& r) {
  if (const auto* c = std::get_if<modbus::WriteCoilRequest>(&r)) {
    return modbus::WriteCoilResponse{c->coil, c->value};
  }
  if (const auto* c = std::get_if<modbus::WriteCoilsRequest>(&r)) {
    return modbus::WriteMultipleResponse{modbus::FunctionCode::WriteCoils, c->start, c->count};
  }
  const auto& w = std::get<modbus::WriteRegistersRequest>(r);
  return modbus::WriteMultipleResponse{modbus::FunctionCode::WriteRegisters, w.start, w.count};
}

}  // namespace

namespace {

constexpr uint8_t kWriteSingleRegister = 0x06;

// FC06 as the one-register FC10 it stands for (issue 33 rule 4). Our codec
// does not know FC06 (the controller refuses it): this is the gateway's
// extension, so it lives here.
std::optional<modbus::Request> fc06_as_fc10(std::span<const uint8_t> pdu) {
  if (pdu.size() != 5 || pdu[0] != kWriteSingleRegister) return std::nullopt;
  const auto address = static_cast<uint16_t>((pdu[1] << 8) | pdu[2]);
  const uint16_t value[] = {static_cast<uint16_t>((pdu[3] << 8) | pdu[4])};
  return modbus::WriteRegistersRequest::of(address, value);
}

}  // namespace

GatewayDecision decide(const GatewayPolicy& policy, uint8_t unit, std::span<const uint8_t> pdu) {
  const uint8_t fc = pdu.empty() ? 0 : pdu[0];
  std::optional<modbus::Bytes> fc06_echo;
  auto request = modbus::decode_request_pdu(pdu);
  if (!request && policy.accept_fc06 && fc == kWriteSingleRegister) {
    if (pdu.size() != 5) return exception(fc, ExceptionCode::IllegalAccessRange);
    request = *fc06_as_fc10(pdu);
    fc06_echo = modbus::Bytes(pdu.begin(), pdu.end());
  }
  if (!request) {
    return exception(fc, request.error().kind == modbus::ErrorKind::UnknownFunction
                             ? ExceptionCode::IllegalFunction
                             : ExceptionCode::IllegalAccessRange);
  }
  const bool write = modbus::is_write(*request);
  if (unit == modbus::kBroadcastId) {
    if (!policy.allow_broadcast || !write)
      return exception(fc, ExceptionCode::GatewayPathUnavailable);
  } else if (!policy.units.contains(unit)) {
    return exception(fc, ExceptionCode::GatewayPathUnavailable);
  }
  if (write && policy.read_only) return exception(fc, ExceptionCode::IllegalFunction);
  // The map's rules, answered here: no line time for a request the
  // controller can only refuse. The input mode is the controller's to judge.
  if (auto refusal = lec::check_request(*request, true)) return exception(fc, refusal->code);
  LineRequest line{modbus::RequestFrame{unit, std::move(*request)}, {}, 1, Priority::Command, {}};
  line.fc06_echo = std::move(fc06_echo);
  line.priority = priority_of(line.frame, Priority::Command, Priority::Command);
  if (!write) {
    line.max_cache_age = policy.cache_max_age;
    line.attempts = 1 + std::max(0, policy.read_retries);
  }
  return line;
}

std::optional<modbus::Response> tcp_reply(const modbus::RequestFrame& frame, const JobResult& r) {
  const auto fc = modbus::function_of(frame.pdu);
  const auto ex = [&](ExceptionCode c) -> modbus::Response {
    return modbus::ExceptionResponse{fc, static_cast<uint8_t>(fc), c};
  };
  switch (r.failure) {
    case Failure::None:
      if (frame.id == modbus::kBroadcastId) return write_reply(frame.pdu);
      return r.reply->pdu;
    case Failure::NoAnswer:
    case Failure::Offline:
      return ex(ExceptionCode::GatewayTargetFailed);
    case Failure::LineDown:
      return ex(ExceptionCode::GatewayPathUnavailable);
    case Failure::ShuttingDown:
      return ex(ExceptionCode::ServerBusy);
    case Failure::Superseded:  // not carried out: a stop came (docs/protocol-decisions.md)
      return ex(ExceptionCode::ServerDeviceFailure);
    case Failure::Cancelled:
      return std::nullopt;
  }
  return std::nullopt;
}

std::optional<modbus::Bytes> tcp_reply_pdu(const LineRequest& request, const JobResult& r) {
  const bool fc06 = request.fc06_echo.has_value();
  // Written: the controller's answer, or a broadcast's (no reply on the
  // line: the gateway answers for the controllers), is FC06's echo.
  const bool broadcast_written =
      r.failure == Failure::None && request.frame.id == modbus::kBroadcastId;
  if (fc06 &&
      (broadcast_written || (r.failure == Failure::None && r.reply &&
                             !std::holds_alternative<modbus::ExceptionResponse>(r.reply->pdu))))
    return *request.fc06_echo;
  auto reply = tcp_reply(request.frame, r);
  if (!reply) return std::nullopt;
  if (fc06) {
    // An exception to an FC06 names FC06 (86), not the FC10 it was written as.
    if (auto* ex = std::get_if<modbus::ExceptionResponse>(&*reply)) {
      ex->raw_function = 0x06;
    }
  }
  return modbus::encode_response_pdu(*reply);
}

}  // namespace lec6::serve
