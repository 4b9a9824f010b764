// Decoding of requests and replies. Structural: any frame whose shape is
// sound decodes, so the twin can answer a bad count with the controller's
// exception code (the counts are judged by check_counts / lec::check_request).

#include <fmt/format.h>

#include "lec6/modbus/crc.hpp"
#include "lec6/modbus/pdu.hpp"
#include "wire_words.hpp"

namespace lec6::modbus {
namespace {

using detail::get16;

Unexpected<Error> fail(ErrorKind kind, std::string message) {
  return unexpected(Error{kind, std::move(message)});
}

// Checks the ADU's envelope: minimum size and CRC. Returns the PDU span.
Expected<std::span<const uint8_t>, Error> open_adu(std::span<const uint8_t> adu, std::size_t min) {
  if (adu.size() < min) {
    return fail(
        ErrorKind::ShortFrame,
        fmt::format("frame of {} bytes is too short (at least {} needed)", adu.size(), min));
  }
  if (adu.size() > kMaxAdu) {
    return fail(ErrorKind::LongFrame,
                fmt::format("frame of {} bytes exceeds the {}-byte maximum", adu.size(), kMaxAdu));
  }
  if (!crc_ok(adu)) {
    const uint16_t want = crc16(adu.first(adu.size() - 2));
    return fail(ErrorKind::BadCrc,
                fmt::format("CRC {:02X} {:02X} does not match the frame (expected {:02X} {:02X})",
                            adu[adu.size() - 2], adu[adu.size() - 1], want & 0xFF, want >> 8));
  }
  return adu.subspan(1, adu.size() - 3);
}

// Lengths are quoted as RTU frame lengths (ID + PDU + CRC), which is what a
// user sees in a trace.
Unexpected<Error> wrong_length(std::string_view what, std::size_t got, std::size_t want) {
  return fail(got < want ? ErrorKind::ShortFrame : ErrorKind::LongFrame,
              fmt::format("{} frame has {} bytes, its shape needs {}", what, got + 3, want + 3));
}

Unexpected<Error> unknown_function(uint8_t fc) {
  return fail(ErrorKind::UnknownFunction,
              fmt::format("function code {:02X}h is not one the controller has", fc));
}

Expected<Response, Error> decode_exception(std::span<const uint8_t> pdu, ExceptionSource source) {
  const uint8_t base = pdu[0] & static_cast<uint8_t>(~kExceptionFlag);
  if (pdu.size() != 2) return wrong_length("exception", pdu.size(), 2);
  const uint8_t code = pdu[1];
  const bool gateway_code = code == 0x04 || code == 0x06 || code == 0x0A || code == 0x0B;
  if (!is_controller_exception(code) && !(source == ExceptionSource::Gateway && gateway_code)) {
    return fail(ErrorKind::BadValue,
                fmt::format("exception code {:02X}h is not one the {} sends", code,
                            source == ExceptionSource::Gateway ? "gateway" : "controller"));
  }
  return Response{
      ExceptionResponse{static_cast<FunctionCode>(base), base, static_cast<ExceptionCode>(code)}};
}

Expected<Response, Error> decode_read_reply(FunctionCode code, std::span<const uint8_t> pdu) {
  if (pdu.size() < 2) return wrong_length(function_name(code), pdu.size(), 2);
  const std::size_t n = pdu[1];
  if (pdu.size() != 2 + n) {
    return fail(
        ErrorKind::BadByteCount,
        fmt::format("byte count {} disagrees with the {} data bytes present", n, pdu.size() - 2));
  }
  if (code != FunctionCode::ReadRegisters) {
    return Response{ReadBitsResponse{code, Bytes(pdu.begin() + 2, pdu.end())}};
  }
  if (n % 2)
    return fail(ErrorKind::BadByteCount, fmt::format("odd byte count {} for registers", n));
  ReadRegistersResponse r;
  r.values.reserve(n / 2);
  for (std::size_t i = 0; i < n; i += 2) r.values.push_back(get16(pdu, 2 + i));
  return Response{std::move(r)};
}

}  // namespace

Expected<Request, Error> decode_request_pdu(std::span<const uint8_t> pdu) {
  if (pdu.empty()) return fail(ErrorKind::ShortFrame, "empty PDU: no function code");
  const uint8_t fc = pdu[0];
  if (!is_known_function(fc)) return unknown_function(fc);
  const auto code = static_cast<FunctionCode>(fc);
  const bool multi = code == FunctionCode::WriteCoils || code == FunctionCode::WriteRegisters;
  if (!multi && pdu.size() != 5) return wrong_length(function_name(code), pdu.size(), 5);
  if (multi) {
    if (pdu.size() < 6) return wrong_length(function_name(code), pdu.size(), 6);
    const std::size_t byte_count = pdu[5];
    if (pdu.size() != 6 + byte_count) {
      return fail(ErrorKind::BadByteCount,
                  fmt::format("byte count {} disagrees with the {} data bytes present", byte_count,
                              pdu.size() - 6));
    }
  }
  const uint16_t a = get16(pdu, 1);
  const uint16_t b = get16(pdu, 3);
  switch (code) {
    case FunctionCode::ReadCoils:
    case FunctionCode::ReadInputs:
      return Request{ReadBitsRequest{code, a, b}};
    case FunctionCode::ReadRegisters:
      return Request{ReadRegistersRequest{a, b}};
    case FunctionCode::WriteCoil:
      return Request{WriteCoilRequest{a, b}};
    case FunctionCode::Echo:
      return Request{EchoRequest{a, b}};
    case FunctionCode::WriteCoils:
      return Request{WriteCoilsRequest{a, b, Bytes(pdu.begin() + 6, pdu.end())}};
    case FunctionCode::WriteRegisters:
      return Request{WriteRegistersRequest{a, b, Bytes(pdu.begin() + 6, pdu.end())}};
  }
  return unknown_function(fc);
}

Expected<Response, Error> decode_response_pdu(std::span<const uint8_t> pdu,
                                              ExceptionSource source) {
  if (pdu.empty()) return fail(ErrorKind::ShortFrame, "empty PDU: no function code");
  const uint8_t fc = pdu[0];
  if (fc & kExceptionFlag) return decode_exception(pdu, source);
  if (!is_known_function(fc)) return unknown_function(fc);
  const auto code = static_cast<FunctionCode>(fc);
  switch (code) {
    case FunctionCode::ReadCoils:
    case FunctionCode::ReadInputs:
    case FunctionCode::ReadRegisters:
      return decode_read_reply(code, pdu);
    default:
      break;
  }
  if (pdu.size() != 5) return wrong_length(function_name(code), pdu.size(), 5);
  const uint16_t a = get16(pdu, 1);
  const uint16_t b = get16(pdu, 3);
  switch (code) {
    case FunctionCode::WriteCoil:
      return Response{WriteCoilResponse{a, b}};
    case FunctionCode::Echo:
      return Response{EchoResponse{a, b}};
    default:
      return Response{WriteMultipleResponse{code, a, b}};
  }
}

Expected<RequestFrame, Error> decode_request(std::span<const uint8_t> adu) {
  auto pdu = open_adu(adu, 4);
  if (!pdu) return unexpected(pdu.error());
  auto req = decode_request_pdu(*pdu);
  if (!req) return unexpected(req.error());
  return RequestFrame{adu[0], std::move(*req)};
}

Expected<ResponseFrame, Error> decode_response(std::span<const uint8_t> adu) {
  auto pdu = open_adu(adu, 5);
  if (!pdu) return unexpected(pdu.error());
  auto rsp = decode_response_pdu(*pdu);
  if (!rsp) return unexpected(rsp.error());
  return ResponseFrame{adu[0], std::move(*rsp)};
}

}  // namespace lec6::modbus
