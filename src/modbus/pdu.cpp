#include "lec6/modbus/pdu.hpp"

#include <fmt/format.h>

#include <cctype>

#include "lec6/modbus/crc.hpp"

namespace lec6::modbus {
namespace {

void put16(Bytes& out, uint16_t v) {
  out.push_back(static_cast<uint8_t>(v >> 8));
  out.push_back(static_cast<uint8_t>(v & 0xFF));
}

uint16_t get16(std::span<const uint8_t> in, std::size_t at) {
  return static_cast<uint16_t>((in[at] << 8) | in[at + 1]);
}

Bytes pack_bits(std::span<const bool> bits) {
  Bytes packed((bits.size() + 7) / 8, 0);
  for (std::size_t i = 0; i < bits.size(); ++i) {
    if (bits[i]) packed[i / 8] = static_cast<uint8_t>(packed[i / 8] | (1U << (i % 8)));
  }
  return packed;
}

bool packed_bit(const Bytes& packed, std::size_t i) {
  return i / 8 < packed.size() && ((packed[i / 8] >> (i % 8)) & 1U);
}

Unexpected<Error> fail(ErrorKind kind, std::string message) {
  return unexpected(Error{kind, std::move(message)});
}

Expected<void, Error> check_count(std::string_view what, uint16_t count, uint16_t max) {
  if (count < 1 || count > max) {
    return fail(
        ErrorKind::CountOutOfRange,
        fmt::format("{} of {}: the controller accepts 1 to {} (digest §2)", what, count, max));
  }
  return {};
}

Expected<void, Error> check_request(const Request& r) {
  struct Visitor {
    Expected<void, Error> operator()(const ReadBitsRequest& q) const {
      return check_count(
          q.function == FunctionCode::ReadCoils ? "read of Y coils" : "read of X inputs", q.count,
          kMaxReadBits);
    }
    Expected<void, Error> operator()(const ReadRegistersRequest& q) const {
      return check_count("read of D registers", q.count, kMaxReadRegisters);
    }
    Expected<void, Error> operator()(const WriteCoilRequest& q) const {
      if (q.value != kCoilOn && q.value != kCoilOff) {
        return fail(
            ErrorKind::BadValue,
            fmt::format("coil value {:04X}h: FC05 takes FF00h (ON) or 0000h (OFF)", q.value));
      }
      return {};
    }
    Expected<void, Error> operator()(const EchoRequest&) const { return {}; }
    Expected<void, Error> operator()(const WriteCoilsRequest& q) const {
      if (auto c = check_count("write of Y coils", q.count, kMaxWriteCoils); !c) return c;
      if (q.packed.size() != (q.count + 7u) / 8u) {
        return fail(ErrorKind::BadByteCount,
                    fmt::format("{} coils need {} data bytes, {} given", q.count, (q.count + 7) / 8,
                                q.packed.size()));
      }
      return {};
    }
    Expected<void, Error> operator()(const WriteRegistersRequest& q) const {
      if (auto c = check_count("write of D registers", q.count, kMaxWriteRegisters); !c) return c;
      if (q.data.size() != 2u * q.count) {
        return fail(ErrorKind::BadByteCount,
                    fmt::format("{} registers need {} data bytes, {} given", q.count, 2 * q.count,
                                q.data.size()));
      }
      return {};
    }
  };
  return std::visit(Visitor{}, r);
}

void encode_request_pdu(const Request& r, Bytes& out) {
  out.push_back(static_cast<uint8_t>(function_of(r)));
  struct Visitor {
    Bytes& out;
    void operator()(const ReadBitsRequest& q) const { put16(out, q.start), put16(out, q.count); }
    void operator()(const ReadRegistersRequest& q) const {
      put16(out, q.start), put16(out, q.count);
    }
    void operator()(const WriteCoilRequest& q) const { put16(out, q.coil), put16(out, q.value); }
    void operator()(const EchoRequest& q) const { put16(out, q.test_code), put16(out, q.data); }
    void operator()(const WriteCoilsRequest& q) const {
      put16(out, q.start), put16(out, q.count);
      out.push_back(static_cast<uint8_t>(q.packed.size()));
      out.insert(out.end(), q.packed.begin(), q.packed.end());
    }
    void operator()(const WriteRegistersRequest& q) const {
      put16(out, q.start), put16(out, q.count);
      out.push_back(static_cast<uint8_t>(q.data.size()));
      out.insert(out.end(), q.data.begin(), q.data.end());
    }
  };
  std::visit(Visitor{out}, r);
}

void encode_response_pdu(const Response& r, Bytes& out) {
  struct Visitor {
    Bytes& out;
    void operator()(const ReadBitsResponse& a) const {
      out.push_back(static_cast<uint8_t>(a.function));
      out.push_back(static_cast<uint8_t>(a.packed.size()));
      out.insert(out.end(), a.packed.begin(), a.packed.end());
    }
    void operator()(const ReadRegistersResponse& a) const {
      out.push_back(static_cast<uint8_t>(FunctionCode::ReadRegisters));
      out.push_back(static_cast<uint8_t>(a.values.size() * 2));
      for (uint16_t v : a.values) put16(out, v);
    }
    void operator()(const WriteCoilResponse& a) const {
      out.push_back(static_cast<uint8_t>(FunctionCode::WriteCoil));
      put16(out, a.coil), put16(out, a.value);
    }
    void operator()(const EchoResponse& a) const {
      out.push_back(static_cast<uint8_t>(FunctionCode::Echo));
      put16(out, a.test_code), put16(out, a.data);
    }
    void operator()(const WriteMultipleResponse& a) const {
      out.push_back(static_cast<uint8_t>(a.function));
      put16(out, a.start), put16(out, a.count);
    }
    void operator()(const ExceptionResponse& a) const {
      const uint8_t fc = a.raw_function ? a.raw_function : static_cast<uint8_t>(a.function);
      out.push_back(static_cast<uint8_t>(fc | kExceptionFlag));
      out.push_back(static_cast<uint8_t>(a.code));
    }
  };
  std::visit(Visitor{out}, r);
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

Unexpected<Error> wrong_length(std::string_view what, std::size_t got, std::size_t want) {
  return fail(got < want ? ErrorKind::ShortFrame : ErrorKind::LongFrame,
              fmt::format("{} frame has {} bytes, its shape needs {}", what, got + 3, want + 3));
}

Expected<Request, Error> decode_request_pdu(std::span<const uint8_t> pdu) {
  const uint8_t fc = pdu[0];
  if (!is_known_function(fc)) {
    return fail(ErrorKind::UnknownFunction,
                fmt::format("function code {:02X}h is not one the controller has", fc));
  }
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
  return fail(ErrorKind::UnknownFunction, "unreachable");
}

Expected<Response, Error> decode_response_pdu(std::span<const uint8_t> pdu) {
  const uint8_t fc = pdu[0];
  const uint8_t base = fc & static_cast<uint8_t>(~kExceptionFlag);
  if (fc & kExceptionFlag) {
    if (pdu.size() != 2) return wrong_length("exception", pdu.size(), 2);
    if (pdu[1] < 1 || pdu[1] > 3) {
      return fail(ErrorKind::BadValue,
                  fmt::format("exception code {:02X}h is not one the controller sends", pdu[1]));
    }
    return Response{ExceptionResponse{static_cast<FunctionCode>(base), base,
                                      static_cast<ExceptionCode>(pdu[1])}};
  }
  if (!is_known_function(fc)) {
    return fail(ErrorKind::UnknownFunction,
                fmt::format("function code {:02X}h is not one the controller has", fc));
  }
  const auto code = static_cast<FunctionCode>(fc);
  switch (code) {
    case FunctionCode::ReadCoils:
    case FunctionCode::ReadInputs:
    case FunctionCode::ReadRegisters: {
      if (pdu.size() < 2) return wrong_length(function_name(code), pdu.size(), 2);
      const std::size_t n = pdu[1];
      if (pdu.size() != 2 + n) {
        return fail(ErrorKind::BadByteCount,
                    fmt::format("byte count {} disagrees with the {} data bytes present", n,
                                pdu.size() - 2));
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

}  // namespace

bool is_known_function(uint8_t fc) noexcept {
  switch (fc) {
    case 0x01:
    case 0x02:
    case 0x03:
    case 0x05:
    case 0x08:
    case 0x0F:
    case 0x10:
      return true;
    default:
      return false;
  }
}

std::string_view function_name(FunctionCode fc) noexcept {
  switch (fc) {
    case FunctionCode::ReadCoils:
      return "read Y coils (01)";
    case FunctionCode::ReadInputs:
      return "read X inputs (02)";
    case FunctionCode::ReadRegisters:
      return "read D registers (03)";
    case FunctionCode::WriteCoil:
      return "write Y coil (05)";
    case FunctionCode::Echo:
      return "echo back (08)";
    case FunctionCode::WriteCoils:
      return "write Y coils (0F)";
    case FunctionCode::WriteRegisters:
      return "write D registers (10)";
  }
  return "unknown function";
}

std::string_view exception_name(ExceptionCode code) noexcept {
  switch (code) {
    case ExceptionCode::IllegalFunction:
      return "illegal function";
    case ExceptionCode::IllegalAddress:
      return "outside address range";
    case ExceptionCode::IllegalAccessRange:
      return "outside access point range";
  }
  return "unknown exception";
}

std::string_view error_kind_name(ErrorKind k) noexcept {
  switch (k) {
    case ErrorKind::ShortFrame:
      return "short frame";
    case ErrorKind::LongFrame:
      return "long frame";
    case ErrorKind::BadCrc:
      return "bad CRC";
    case ErrorKind::UnknownFunction:
      return "unknown function";
    case ErrorKind::BadByteCount:
      return "bad byte count";
    case ErrorKind::CountOutOfRange:
      return "count out of range";
    case ErrorKind::BadValue:
      return "bad value";
  }
  return "error";
}

WriteCoilsRequest WriteCoilsRequest::of(uint16_t start, std::span<const bool> bits) {
  return {start, static_cast<uint16_t>(bits.size()), pack_bits(bits)};
}
bool WriteCoilsRequest::bit(std::size_t i) const noexcept {
  return packed_bit(packed, i);
}
bool ReadBitsResponse::bit(std::size_t i) const noexcept {
  return packed_bit(packed, i);
}

WriteRegistersRequest WriteRegistersRequest::of(uint16_t start, std::span<const uint16_t> values) {
  WriteRegistersRequest r{start, static_cast<uint16_t>(values.size()), {}};
  r.data.reserve(values.size() * 2);
  for (uint16_t v : values) put16(r.data, v);
  return r;
}

std::vector<uint16_t> WriteRegistersRequest::values() const {
  std::vector<uint16_t> out;
  out.reserve(data.size() / 2);
  for (std::size_t i = 0; i + 1 < data.size(); i += 2) out.push_back(get16(data, i));
  return out;
}

FunctionCode function_of(const Request& r) noexcept {
  struct Visitor {
    FunctionCode operator()(const ReadBitsRequest& q) const { return q.function; }
    FunctionCode operator()(const ReadRegistersRequest&) const {
      return FunctionCode::ReadRegisters;
    }
    FunctionCode operator()(const WriteCoilRequest&) const { return FunctionCode::WriteCoil; }
    FunctionCode operator()(const EchoRequest&) const { return FunctionCode::Echo; }
    FunctionCode operator()(const WriteCoilsRequest&) const { return FunctionCode::WriteCoils; }
    FunctionCode operator()(const WriteRegistersRequest&) const {
      return FunctionCode::WriteRegisters;
    }
  };
  return std::visit(Visitor{}, r);
}

bool is_write(const Request& r) noexcept {
  const auto fc = function_of(r);
  return fc == FunctionCode::WriteCoil || fc == FunctionCode::WriteCoils ||
         fc == FunctionCode::WriteRegisters;
}

void append_crc(Bytes& body) {
  const uint16_t crc = crc16(body);
  body.push_back(static_cast<uint8_t>(crc & 0xFF));
  body.push_back(static_cast<uint8_t>(crc >> 8));
}

Expected<Bytes, Error> encode_request(const RequestFrame& frame) {
  if (auto ok = check_request(frame.pdu); !ok) return unexpected(ok.error());
  Bytes out;
  out.reserve(kMaxAdu);
  out.push_back(frame.id);
  encode_request_pdu(frame.pdu, out);
  append_crc(out);
  return out;
}

Bytes encode_response(const ResponseFrame& frame) {
  Bytes out;
  out.reserve(kMaxAdu);
  out.push_back(frame.id);
  encode_response_pdu(frame.pdu, out);
  append_crc(out);
  return out;
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

std::size_t expected_response_length(const Request& request) noexcept {
  struct Visitor {
    std::size_t operator()(const ReadBitsRequest& q) const { return 5 + (q.count + 7u) / 8u; }
    std::size_t operator()(const ReadRegistersRequest& q) const { return 5 + 2u * q.count; }
    std::size_t operator()(const WriteCoilRequest&) const { return 8; }
    std::size_t operator()(const EchoRequest&) const { return 8; }
    std::size_t operator()(const WriteCoilsRequest&) const { return 8; }
    std::size_t operator()(const WriteRegistersRequest&) const { return 8; }
  };
  return std::visit(Visitor{}, request);
}

std::string to_hex(std::span<const uint8_t> bytes) {
  std::string out;
  out.reserve(bytes.size() * 3);
  for (std::size_t i = 0; i < bytes.size(); ++i) {
    if (i) out.push_back(' ');
    fmt::format_to(std::back_inserter(out), "{:02X}", bytes[i]);
  }
  return out;
}

Expected<Bytes, std::string> from_hex(std::string_view text) {
  Bytes out;
  int pending = -1;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (c == '0' && i + 1 < text.size() && (text[i + 1] == 'x' || text[i + 1] == 'X') &&
        pending < 0) {
      ++i;  // "0x" prefix
      continue;
    }
    if (std::isspace(static_cast<unsigned char>(c)) || c == ',' || c == ':' || c == '-') {
      if (pending >= 0)
        return unexpected(fmt::format("'{}' has a lone hex digit before position {}", text, i));
      continue;
    }
    if (!std::isxdigit(static_cast<unsigned char>(c))) {
      return unexpected(fmt::format("'{}' is not hex: unexpected '{}' at position {}", text, c, i));
    }
    const int v =
        std::isdigit(static_cast<unsigned char>(c)) ? c - '0' : (std::tolower(c) - 'a' + 10);
    if (pending < 0) {
      pending = v;
    } else {
      out.push_back(static_cast<uint8_t>(pending * 16 + v));
      pending = -1;
    }
  }
  if (pending >= 0) return unexpected(fmt::format("'{}' has an odd number of hex digits", text));
  return out;
}

}  // namespace lec6::modbus
