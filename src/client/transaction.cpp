#include "lec6/client/transaction.hpp"

#include <fmt/format.h>

namespace lec6::client {

std::string_view transport_error_name(TransportErrorKind k) noexcept {
  switch (k) {
    case TransportErrorKind::Port:
      return "port";
    case TransportErrorKind::Timeout:
      return "timeout";
    case TransportErrorKind::Crc:
      return "CRC";
    case TransportErrorKind::Framing:
      return "framing";
    case TransportErrorKind::EchoMismatch:
      return "echo mismatch";
    case TransportErrorKind::LineBusy:
      return "line busy";
    case TransportErrorKind::Unreachable:
      return "unreachable";
  }
  return "transport";
}

bool is_line_fault(TransportErrorKind k) noexcept {
  return k == TransportErrorKind::Timeout || k == TransportErrorKind::Crc ||
         k == TransportErrorKind::Framing || k == TransportErrorKind::EchoMismatch ||
         k == TransportErrorKind::LineBusy;
}

Transaction::Transaction(const modbus::RequestFrame& request, const TransactionTiming& timing)
    : request_(request), timing_(timing) {
  auto encoded = modbus::encode_request(request);
  if (!encoded) throw InvalidRequest(encoded.error().message);
  query_ = std::move(*encoded);
  framer_.expect(request.id, request.pdu);
}

void Transaction::sent(TimePoint t) {
  sent_at_ = t;
  const std::size_t reply = modbus::expected_response_length(request_.pdu);
  if (broadcast()) {
    // No reply comes; the line is ours again after Tx (manual §8.4).
    deadline_ = t + timing_.line.response_time(reply);
    step_ = Step::Receive;
    return;
  }
  deadline_ = t + timing_.line.response_time(reply) + timing_.margin;
  step_ = Step::Receive;
}

void Transaction::received(std::span<const uint8_t> bytes, TimePoint t) {
  if (step_ != Step::Receive || broadcast())
    return;  // a broadcast has no reply; ignore stray bytes
  if (framer_.feed(bytes) != modbus::ClientFramer::Status::Complete) return;
  auto decoded = modbus::decode_response(framer_.frame());
  if (!decoded) {
    // The framer verified ID, function, length and CRC, so this is a reply the
    // controller could not have sent (e.g. exception code 07).
    fail(TransportErrorKind::Framing, fmt::format("malformed reply: {}", decoded.error().message),
         t);
    return;
  }
  response_ = std::move(*decoded);
  finished_at_ = t;
  step_ = Step::Done;
}

void Transaction::timed_out(TimePoint t) {
  if (step_ != Step::Receive) return;
  if (broadcast()) {
    finished_at_ = t;
    step_ = Step::Done;
    return;
  }
  const double waited = to_ms(t - sent_at_);
  if (framer_.crc_failures() > 0) {
    fail(TransportErrorKind::Crc,
         fmt::format(
             "reply failed the CRC check ({} bad candidate(s), {} bytes dropped) — noise on the "
             "line, or a baud rate that does not match the controller's",
             framer_.crc_failures(), framer_.discarded()),
         t);
  } else if (framer_.discarded() > 0 || framer_.buffered() > 0) {
    fail(TransportErrorKind::Framing,
         fmt::format(
             "no valid reply from ID {} in {:.1f} ms: {} stray byte(s) ({}), {} byte(s) of an "
             "incomplete reply — noise on the line, two devices answering, or a baud rate that "
             "does not match the controller's",
             request_.id, waited, framer_.discarded(), modbus::discard_name(framer_.last_discard()),
             framer_.buffered()),
         t);
  } else {
    fail(TransportErrorKind::Timeout,
         fmt::format(
             "no reply from ID {} within {:.1f} ms (Tx + margin) — check the ID, baud rate, wiring "
             "and that the controller is powered",
             request_.id, waited),
         t);
  }
}

void Transaction::fail(TransportErrorKind kind, std::string why, TimePoint t) {
  error_kind_ = kind;
  error_ = std::move(why);
  finished_at_ = t;
  step_ = Step::Failed;
}

}  // namespace lec6::client
