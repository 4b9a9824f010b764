// Encoding of requests and replies (digest §2), with the count limits that
// decide what the controller refuses with exception 03.

#include <fmt/format.h>

#include "lec6/modbus/crc.hpp"
#include "lec6/modbus/pdu.hpp"
#include "wire_words.hpp"

namespace lec6::modbus {
namespace {

using detail::put16;

Error count_error(std::string_view what, uint16_t count, uint16_t max) {
  return Error{
      ErrorKind::CountOutOfRange,
      fmt::format("{} of {}: the controller accepts 1 to {} (digest §2)", what, count, max)};
}

std::optional<Error> check_count(std::string_view what, uint16_t count, uint16_t max) {
  if (count < 1 || count > max) return count_error(what, count, max);
  return std::nullopt;
}

std::optional<Error> check_byte_count(std::string_view unit, uint16_t count, std::size_t need,
                                      std::size_t given) {
  if (given == need) return std::nullopt;
  return Error{ErrorKind::BadByteCount,
               fmt::format("{} {} need {} data bytes, {} given", count, unit, need, given)};
}

std::optional<Error> check_value(const Request& r) {
  const auto* q = std::get_if<WriteCoilRequest>(&r);
  if (!q || q->value == kCoilOn || q->value == kCoilOff) return std::nullopt;
  return Error{ErrorKind::BadValue,
               fmt::format("coil value {:04X}h: FC05 takes FF00h (ON) or 0000h (OFF)", q->value)};
}

void put_request_pdu(const Request& r, Bytes& out) {
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

void put_response_pdu(const Response& r, Bytes& out) {
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

}  // namespace

std::optional<Error> check_counts(const Request& r) {
  struct Visitor {
    std::optional<Error> operator()(const ReadBitsRequest& q) const {
      return check_count(
          q.function == FunctionCode::ReadCoils ? "read of Y coils" : "read of X inputs", q.count,
          kMaxReadBits);
    }
    std::optional<Error> operator()(const ReadRegistersRequest& q) const {
      return check_count("read of D registers", q.count, kMaxReadRegisters);
    }
    std::optional<Error> operator()(const WriteCoilRequest&) const { return std::nullopt; }
    std::optional<Error> operator()(const EchoRequest&) const { return std::nullopt; }
    std::optional<Error> operator()(const WriteCoilsRequest& q) const {
      if (auto e = check_count("write of Y coils", q.count, kMaxWriteCoils)) return e;
      return check_byte_count("coils", q.count, (q.count + 7u) / 8u, q.packed.size());
    }
    std::optional<Error> operator()(const WriteRegistersRequest& q) const {
      if (auto e = check_count("write of D registers", q.count, kMaxWriteRegisters)) return e;
      return check_byte_count("registers", q.count, 2u * q.count, q.data.size());
    }
  };
  return std::visit(Visitor{}, r);
}

Expected<Bytes, Error> encode_request_pdu(const Request& request) {
  if (auto e = check_counts(request)) return unexpected(std::move(*e));
  if (auto e = check_value(request)) return unexpected(std::move(*e));
  Bytes out;
  out.reserve(kMaxAdu);
  put_request_pdu(request, out);
  return out;
}

Bytes encode_response_pdu(const Response& response) {
  Bytes out;
  out.reserve(kMaxAdu);
  put_response_pdu(response, out);
  return out;
}

void append_crc(Bytes& body) {
  const uint16_t crc = crc16(body);
  body.push_back(static_cast<uint8_t>(crc & 0xFF));
  body.push_back(static_cast<uint8_t>(crc >> 8));
}

Expected<Bytes, Error> encode_request(const RequestFrame& frame) {
  if (auto e = check_counts(frame.pdu)) return unexpected(std::move(*e));
  if (auto e = check_value(frame.pdu)) return unexpected(std::move(*e));
  Bytes out;
  out.reserve(kMaxAdu);
  out.push_back(frame.id);
  put_request_pdu(frame.pdu, out);
  append_crc(out);
  return out;
}

Bytes encode_response(const ResponseFrame& frame) {
  Bytes out;
  out.reserve(kMaxAdu);
  out.push_back(frame.id);
  put_response_pdu(frame.pdu, out);
  append_crc(out);
  return out;
}

}  // namespace lec6::modbus
