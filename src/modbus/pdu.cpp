// Requests and replies as values: names, constructors and shapes.

#include "lec6/modbus/pdu.hpp"

#include <fmt/format.h>

#include "wire_words.hpp"

namespace lec6::modbus {
namespace {

using detail::get16;
using detail::put16;

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

}  // namespace

bool is_controller_exception(uint8_t code) noexcept {
  return code >= 0x01 && code <= 0x03;
}

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
    case ExceptionCode::ServerDeviceFailure:
      return "server device failure";
    case ExceptionCode::ServerBusy:
      return "server device busy";
    case ExceptionCode::GatewayPathUnavailable:
      return "gateway path unavailable";
    case ExceptionCode::GatewayTargetFailed:
      return "gateway target device failed to respond";
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

}  // namespace lec6::modbus
