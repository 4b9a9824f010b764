#pragma once
// Frame-length prediction from a frame's first bytes. This is what lets the
// client finish a read the moment the last byte is in, instead of waiting for
// a silent interval to find the end.
//
// Thread safety: pure functions.

#include <cstddef>
#include <cstdint>
#include <span>

namespace lec6::modbus {

struct FrameLength {
  enum class Status {
    NeedMore,  // not enough bytes yet to know
    Known,     // `bytes` is the whole frame's length, CRC included
    Unknown,   // the frame cannot be sized (unknown function code)
  };
  Status status = Status::NeedMore;
  std::size_t bytes = 0;

  static constexpr FrameLength need_more() { return {Status::NeedMore, 0}; }
  static constexpr FrameLength known(std::size_t n) { return {Status::Known, n}; }
  static constexpr FrameLength unknown() { return {Status::Unknown, 0}; }
};

// Length of a request (master → controller) from its first bytes.
FrameLength request_length(std::span<const uint8_t> head) noexcept;

// Length of a reply (controller → master), normal or exception, from its first bytes.
FrameLength response_length(std::span<const uint8_t> head) noexcept;

}  // namespace lec6::modbus
