#pragma once
// Modbus TCP framing (the MBAP header of the Modbus Messaging on TCP/IP
// Implementation Guide), sans-I/O: what `lec serve` accepts from PLCs and
// SCADA, and what `lec --port tcp://` sends.
//
//   [transaction id 2][protocol id 2 = 0][length 2][unit id 1][PDU]
//
// `length` counts the unit id and the PDU. There is no CRC: TCP checks the
// bytes. The unit id addresses a controller behind the gateway (its ID).
//
// Thread safety: free functions are pure; an MbapFramer is used by one thread.

#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>

#include "lec6/modbus/pdu.hpp"

namespace lec6::modbus {

inline constexpr std::size_t kMbapHeaderSize = 7;  // including the unit id
// The largest PDU a Modbus TCP ADU carries (260-byte ADU − 7-byte header);
// every request and reply the LEC map allows fits (digest §2).
inline constexpr std::size_t kMaxMbapPdu = 253;

struct MbapHeader {
  uint16_t transaction = 0;
  uint16_t protocol = 0;  // 0 = Modbus
  uint16_t length = 0;    // unit id + PDU
  uint8_t unit = 0;
  bool operator==(const MbapHeader&) const = default;
};

struct MbapAdu {
  MbapHeader header;
  Bytes pdu;
  bool operator==(const MbapAdu&) const = default;
};

// [header][pdu] with length = 1 + pdu.size().
Bytes encode_mbap(uint16_t transaction, uint8_t unit, std::span<const uint8_t> pdu);

// Cuts a TCP byte stream into ADUs. A stream that breaks the framing (a
// protocol id other than 0, a length outside 2..254) cannot be resynchronised
// — MBAP has no delimiter — so the framer fails for good and the connection
// must be closed.
class MbapFramer {
 public:
  enum class Status { Incomplete, Complete, Broken };

  // Appends bytes; returns Complete when at least one ADU is ready.
  Status feed(std::span<const uint8_t> bytes);
  // The next complete ADU, if any (call until nullopt after each feed).
  std::optional<MbapAdu> next();
  Status status() const noexcept { return broken_ ? Status::Broken : ready_status(); }
  // Why the stream broke, in words for a log line.
  const std::string& error() const noexcept { return error_; }
  std::size_t buffered() const noexcept { return buffer_.size(); }

 private:
  Status ready_status() const noexcept;
  bool check_header();

  Bytes buffer_;
  bool broken_ = false;
  std::string error_;
};

}  // namespace lec6::modbus
