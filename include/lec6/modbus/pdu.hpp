#pragma once
// Modbus RTU frames as the LEC□6 speaks them (digest §2): the function codes
// it knows, requests and replies as typed values, and their encoding.
//
// Encoding is strict (it refuses what the controller would refuse on counts);
// decoding is structural (it accepts any frame whose shape is sound, so the
// twin can answer a bad count with the controller's exception code).
//
// Thread safety: value types and pure functions; const objects may be shared between threads.

#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "lec6/expected.hpp"

namespace lec6::modbus {

using Bytes = std::vector<uint8_t>;

enum class FunctionCode : uint8_t {
  ReadCoils = 0x01,       // read Y
  ReadInputs = 0x02,      // read X
  ReadRegisters = 0x03,   // read D
  WriteCoil = 0x05,       // write one Y
  Echo = 0x08,            // echo back (diagnostics, test code 0000)
  WriteCoils = 0x0F,      // write several Y
  WriteRegisters = 0x10,  // write several D
};

inline constexpr uint8_t kExceptionFlag = 0x80;
inline constexpr uint8_t kBroadcastId = 0;

enum class ExceptionCode : uint8_t {
  IllegalFunction = 0x01,     // manual: "Illegal function"
  IllegalAddress = 0x02,      // manual: "Outside address range"
  IllegalAccessRange = 0x03,  // manual: "Outside access point range"
  // Codes a controller never sends but a Modbus TCP gateway (`lec serve`) does,
  // per the Modbus application protocol specification §7.
  ServerDeviceFailure = 0x04,     // the gateway failed while handling the request
  ServerBusy = 0x06,              // the gateway is shutting down: try again later
  GatewayPathUnavailable = 0x0A,  // no such unit behind the gateway
  GatewayTargetFailed = 0x0B,     // the unit did not answer
};

// Whether a controller on a serial line can send this code (01–03), as
// opposed to a gateway-only code.
bool is_controller_exception(uint8_t code) noexcept;

bool is_known_function(uint8_t fc) noexcept;
std::string_view function_name(FunctionCode fc) noexcept;
std::string_view exception_name(ExceptionCode code) noexcept;

inline constexpr uint16_t kCoilOn = 0xFF00;
inline constexpr uint16_t kCoilOff = 0x0000;

// Frame limits (digest §2): data ≤ 256 bytes, so an ADU is at most 260 bytes.
inline constexpr std::size_t kMaxData = 256;
inline constexpr std::size_t kMaxAdu = 1 + 1 + kMaxData + 2;
// Count limits (digest §2); a count outside them is answered with exception 03.
inline constexpr uint16_t kMaxReadBits = 2000;
inline constexpr uint16_t kMaxReadRegisters = 125;
inline constexpr uint16_t kMaxWriteCoils = 256;
inline constexpr uint16_t kMaxWriteRegisters = 123;

// ---- requests -------------------------------------------------------------

struct ReadBitsRequest {  // FC01 (Y coils) or FC02 (X inputs)
  FunctionCode function = FunctionCode::ReadInputs;
  uint16_t start = 0;
  uint16_t count = 0;
  bool operator==(const ReadBitsRequest&) const = default;
};

struct ReadRegistersRequest {  // FC03
  uint16_t start = 0;
  uint16_t count = 0;
  bool operator==(const ReadRegistersRequest&) const = default;
};

struct WriteCoilRequest {  // FC05; the value is kept raw: anything but FF00/0000 is refused (03)
  uint16_t coil = 0;
  uint16_t value = kCoilOff;
  bool on() const noexcept { return value == kCoilOn; }
  bool operator==(const WriteCoilRequest&) const = default;
};

struct EchoRequest {  // FC08; the controller only knows test code 0000
  uint16_t test_code = 0;
  uint16_t data = 0;
  bool operator==(const EchoRequest&) const = default;
};

struct WriteCoilsRequest {  // FC0F; bits packed LSB first, as they travel
  uint16_t start = 0;
  uint16_t count = 0;
  Bytes packed;
  static WriteCoilsRequest of(uint16_t start, std::span<const bool> bits);
  bool bit(std::size_t i) const noexcept;
  bool operator==(const WriteCoilsRequest&) const = default;
};

struct WriteRegistersRequest {  // FC10; data as it travels, big-endian words
  uint16_t start = 0;
  uint16_t count = 0;
  Bytes data;
  static WriteRegistersRequest of(uint16_t start, std::span<const uint16_t> values);
  std::vector<uint16_t> values() const;
  bool operator==(const WriteRegistersRequest&) const = default;
};

using Request = std::variant<ReadBitsRequest, ReadRegistersRequest, WriteCoilRequest, EchoRequest,
                             WriteCoilsRequest, WriteRegistersRequest>;

FunctionCode function_of(const Request& r) noexcept;
bool is_write(const Request& r) noexcept;

// ---- replies --------------------------------------------------------------

struct ReadBitsResponse {  // FC01/02: bits packed LSB first
  FunctionCode function = FunctionCode::ReadInputs;
  Bytes packed;
  bool bit(std::size_t i) const noexcept;
  bool operator==(const ReadBitsResponse&) const = default;
};

struct ReadRegistersResponse {  // FC03
  std::vector<uint16_t> values;
  bool operator==(const ReadRegistersResponse&) const = default;
};

struct WriteCoilResponse {  // FC05: echo of the request
  uint16_t coil = 0;
  uint16_t value = 0;
  bool operator==(const WriteCoilResponse&) const = default;
};

struct EchoResponse {  // FC08: echo of the request
  uint16_t test_code = 0;
  uint16_t data = 0;
  bool operator==(const EchoResponse&) const = default;
};

struct WriteMultipleResponse {  // FC0F/10: start and count of the request
  FunctionCode function = FunctionCode::WriteRegisters;
  uint16_t start = 0;
  uint16_t count = 0;
  bool operator==(const WriteMultipleResponse&) const = default;
};

struct ExceptionResponse {
  FunctionCode function = FunctionCode::ReadRegisters;  // the request's code, without 0x80
  uint8_t raw_function = 0;                             // as requested (may be unknown)
  ExceptionCode code = ExceptionCode::IllegalFunction;
  bool operator==(const ExceptionResponse&) const = default;
};

using Response = std::variant<ReadBitsResponse, ReadRegistersResponse, WriteCoilResponse,
                              EchoResponse, WriteMultipleResponse, ExceptionResponse>;

// ---- frames (ADU = ID + PDU + CRC) ----------------------------------------

struct RequestFrame {
  uint8_t id = 1;
  Request pdu;
  bool operator==(const RequestFrame&) const = default;
};

struct ResponseFrame {
  uint8_t id = 1;
  Response pdu;
  bool operator==(const ResponseFrame&) const = default;
};

// What is wrong with a frame or a request, in words a user can act on.
enum class ErrorKind {
  ShortFrame,       // fewer bytes than the frame's shape needs
  LongFrame,        // more bytes than the frame's shape allows
  BadCrc,           // CRC does not match
  UnknownFunction,  // a function code the controller does not have
  BadByteCount,     // byte count disagrees with the count or the frame length
  CountOutOfRange,  // encode only: a count the controller refuses
  BadValue,         // encode only: e.g. FC05 value other than FF00/0000
};

struct Error {
  ErrorKind kind;
  std::string message;
};

std::string_view error_kind_name(ErrorKind k) noexcept;

// The count limits of digest §2, the one place they are checked: a count
// outside them, or a byte count that disagrees with the count. The client
// refuses such a request before sending; the controller answers it with 03.
std::optional<Error> check_counts(const Request& request);

// Encoding. A request with a count outside digest §2 is refused, so the
// client never sends what the controller would only answer with 03.
Expected<Bytes, Error> encode_request(const RequestFrame& frame);
Bytes encode_response(const ResponseFrame& frame);

// The PDU alone (function code and data, no ID, no CRC): what Modbus TCP
// carries after its MBAP header. Same rules as the ADU functions above.
Expected<Bytes, Error> encode_request_pdu(const Request& request);
Bytes encode_response_pdu(const Response& response);
Expected<Request, Error> decode_request_pdu(std::span<const uint8_t> pdu);
// Which exception codes a reply may carry: a controller sends 01–03 only; a
// gateway also 04, 0A and 0B.
enum class ExceptionSource { Controller, Gateway };
Expected<Response, Error> decode_response_pdu(std::span<const uint8_t> pdu,
                                              ExceptionSource source = ExceptionSource::Controller);

// Appends the CRC to an ADU body (ID + PDU).
void append_crc(Bytes& body);

// Decoding a whole ADU (CRC included). Never reads past `adu`.
Expected<RequestFrame, Error> decode_request(std::span<const uint8_t> adu);
Expected<ResponseFrame, Error> decode_response(std::span<const uint8_t> adu);

// The length of the normal reply to `request` (exception replies are 5 bytes).
std::size_t expected_response_length(const Request& request) noexcept;
inline constexpr std::size_t kExceptionLength = 5;

std::string to_hex(std::span<const uint8_t> bytes);
// Parses "01 05 00 30", "01050030" or "0x01,0x05"; nullopt-like error on odd digits.
Expected<Bytes, std::string> from_hex(std::string_view text);

}  // namespace lec6::modbus
