#include "lec6/transport/modbus_tcp_master.hpp"

#include <fmt/format.h>

#include <array>

#include "lec6/client/errors.hpp"
#include "lec6/lec/explain.hpp"

namespace lec6::transport {
namespace {

using client::TransportError;
using client::TransportErrorKind;

TransportErrorKind kind_of(client::LinkErrorKind k) {
  return k == client::LinkErrorKind::EchoMismatch ? TransportErrorKind::EchoMismatch
                                                  : TransportErrorKind::Port;
}

}  // namespace

ModbusTcpMaster::ModbusTcpMaster(std::string host, uint16_t port, ModbusTcpOptions options)
    : host_(std::move(host)), port_(port), options_(std::move(options)) {
  connect();
}

ModbusTcpMaster::~ModbusTcpMaster() = default;

std::string ModbusTcpMaster::url() const {
  const bool v6 = host_.find(':') != std::string::npos;
  return fmt::format(fmt::runtime(v6 ? "tcp://[{}]:{}" : "tcp://{}:{}"), host_, port_);
}

std::string ModbusTcpMaster::describe() const {
  return url() + " (Modbus TCP)";
}

void ModbusTcpMaster::connect() {
  TcpOptions o;
  o.baud = options_.line.baud;
  o.connect_timeout = options_.connect_timeout;
  o.scheme = "tcp";
  try {
    link_ = std::make_unique<TcpLink>(host_, port_, o);
  } catch (const client::LinkError& e) {
    throw TransportError(TransportErrorKind::Port, e.what());
  }
  framer_ = modbus::MbapFramer{};
}

void ModbusTcpMaster::trace(bool outgoing, TimePoint at, std::span<const uint8_t> bytes,
                            const modbus::RequestFrame& request,
                            const modbus::ResponseFrame* response) {
  if (!options_.trace) return;
  std::string text =
      outgoing ? lec::explain_request(request)
               : (response ? lec::explain_response(*response, &request) : std::string("?"));
  options_.trace(client::TraceEvent{outgoing, at, bytes, std::move(text)});
}

modbus::ResponseFrame ModbusTcpMaster::exchange(const modbus::RequestFrame& frame) {
  auto pdu = modbus::encode_request_pdu(frame.pdu);
  if (!pdu) throw client::InvalidRequest(pdu.error().message);
  if (!link_) connect();
  const uint16_t transaction = next_transaction_++;
  const modbus::Bytes adu = modbus::encode_mbap(transaction, frame.id, *pdu);
  try {
    const TimePoint start = clock_.now();
    link_->write(adu);
    trace(true, start, adu, frame, nullptr);
    ++stats_.transactions;
    return await_reply(frame, transaction, start);
  } catch (const client::LinkError& e) {
    link_.reset();  // the next exchange connects again
    throw TransportError(kind_of(e.kind()), e.what());
  }
}

modbus::ResponseFrame ModbusTcpMaster::await_reply(const modbus::RequestFrame& frame,
                                                   uint16_t transaction, TimePoint start) {
  const TimePoint deadline = start + options_.timeout;
  std::array<uint8_t, 512> buffer{};
  for (;;) {
    while (auto adu = framer_.next()) {
      if (adu->header.transaction == transaction) return checked(frame, *adu, start);
      // A late reply to a request that already timed out: not ours.
      stats_.bytes_discarded += modbus::kMbapHeaderSize + adu->pdu.size();
    }
    if (framer_.status() == modbus::MbapFramer::Status::Broken) {
      ++stats_.framing_errors;
      const std::string why = framer_.error();
      link_.reset();
      throw TransportError(
          TransportErrorKind::Framing,
          fmt::format("{} does not answer in Modbus TCP framing ({}); if it speaks Modbus RTU "
                      "over TCP, use rtu+tcp://{}:{}",
                      url(), why, host_, port_));
    }
    const std::size_t n = link_->read_some(buffer, deadline);
    if (n > 0) {
      framer_.feed(std::span(buffer.data(), n));
    } else if (clock_.now() >= deadline) {
      if (frame.id == modbus::kBroadcastId) {
        // A gateway may not answer a broadcast: the line had it anyway.
        return modbus::ResponseFrame{modbus::kBroadcastId, modbus::WriteMultipleResponse{}};
      }
      ++stats_.timeouts;
      throw TransportError(
          TransportErrorKind::Timeout,
          fmt::format("no reply for unit {} from {} (Modbus TCP) within {:.0f} ms — if that port "
                      "speaks Modbus RTU over TCP (`lec sim --tcp`, a serial device server in "
                      "transparent mode), use rtu+tcp://{}:{}",
                      frame.id, url(), to_ms(options_.timeout), host_, port_));
    }
  }
}

modbus::ResponseFrame ModbusTcpMaster::checked(const modbus::RequestFrame& frame,
                                               const modbus::MbapAdu& adu, TimePoint start) {
  auto pdu = modbus::decode_response_pdu(adu.pdu, modbus::ExceptionSource::Gateway);
  if (!pdu || adu.header.unit != frame.id) {
    ++stats_.framing_errors;
    throw TransportError(
        TransportErrorKind::Framing,
        fmt::format("malformed reply from {}: {}", url(),
                    pdu ? fmt::format("unit {} answered for unit {}", adu.header.unit, frame.id)
                        : pdu.error().message));
  }
  modbus::ResponseFrame reply{frame.id, std::move(*pdu)};
  last_round_trip_ = clock_.now() - start;
  trace(false, clock_.now(), modbus::encode_mbap(adu.header.transaction, adu.header.unit, adu.pdu),
        frame, &reply);
  if (const auto* ex = std::get_if<modbus::ExceptionResponse>(&reply.pdu)) {
    if (ex->code == modbus::ExceptionCode::GatewayPathUnavailable) {
      throw TransportError(
          TransportErrorKind::Unreachable,
          fmt::format("{} has no controller with ID {} (exception 0A, gateway path unavailable): "
                      "check the IDs configured on the gateway",
                      url(), frame.id));
    }
    if (ex->code == modbus::ExceptionCode::GatewayTargetFailed) {
      ++stats_.timeouts;
      throw TransportError(
          TransportErrorKind::Timeout,
          fmt::format("controller ID {} did not answer the gateway {} (exception 0B): check its "
                      "power, wiring, ID and baud rate",
                      frame.id, url()));
    }
  }
  return reply;
}

}  // namespace lec6::transport
