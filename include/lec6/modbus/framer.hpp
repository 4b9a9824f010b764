#pragma once
// Framers, sans-I/O: they are fed bytes (with the time they arrived) and say
// when a frame is complete. No reads, no sleeps, no clocks of their own.
//
// Thread safety: a framer is used by one thread at a time.

#include <cstddef>
#include <cstdint>
#include <deque>
#include <optional>
#include <span>
#include <string_view>

#include "lec6/clock.hpp"
#include "lec6/modbus/pdu.hpp"

namespace lec6::modbus {

// The master's side: it knows the request it sent, so it knows the reply's
// ID, function and normal length. A reply completes on its expected length
// (never on a timeout); bytes that cannot start the reply are dropped one at a
// time until a frame with a good CRC lines up (resynchronisation).
class ClientFramer {
 public:
  struct Expectation {
    uint8_t id = 1;
    FunctionCode function = FunctionCode::ReadRegisters;
    std::size_t normal_length = 8;  // see expected_response_length()
  };

  enum class Status { Incomplete, Complete };

  // Why bytes were dropped: the most telling reason seen in this transaction
  // (ordered: a CRC failure says more about the line than stray bytes do).
  enum class Discard { None, WrongId, WrongFunction, WrongLength, BadCrc };

  // Starts a new transaction; whatever was buffered is dropped (and counted).
  void expect(const Expectation& e);
  void expect(uint8_t id, const Request& request);

  Status feed(std::span<const uint8_t> bytes);

  // The verified reply, valid after feed() returned Complete.
  std::span<const uint8_t> frame() const noexcept { return {buffer_.data(), frame_length_}; }

  // How many more bytes the current candidate needs (at least 1 while incomplete).
  std::size_t bytes_wanted() const noexcept;

  std::size_t discarded() const noexcept { return discarded_; }
  std::size_t crc_failures() const noexcept { return crc_failures_; }
  Discard last_discard() const noexcept { return last_discard_; }
  std::size_t buffered() const noexcept { return buffer_.size(); }

 private:
  Status scan();
  bool is_read() const noexcept;
  void drop_front(Discard why);

  Expectation expect_{};
  Bytes buffer_;
  std::size_t frame_length_ = 0;
  std::size_t discarded_ = 0;
  std::size_t crc_failures_ = 0;
  Discard last_discard_ = Discard::None;
};

std::string_view discard_name(ClientFramer::Discard d) noexcept;

// What ends a frame at the controller's side.
enum class FrameEnd : uint8_t {
  Silence,          // a gap ≥ Ts after the last byte (the manual's rule)
  LengthOrSilence,  // also its predicted length with a valid CRC (the fast twin)
};

// The controller's side: frames are delimited by the silent interval Ts
// (a gap ≥ Ts ends a frame), from the arrival times of the bytes. With
// FrameEnd::LengthOrSilence a frame also completes as soon as its predicted
// length is in with a valid CRC (frames it cannot size still wait for Ts).
class DeviceFramer {
 public:
  struct Frame {
    Bytes bytes;             // at most kMaxAdu + 1: the start of an over-long frame
    TimePoint end_of_query;  // arrival of the frame's last byte
    // Bytes the frame had on the line, and, for an over-long frame (length
    // > kMaxAdu, only its start kept), whether its CRC over all of them holds.
    std::size_t length = 0;
    bool long_crc_ok = false;
  };

  DeviceFramer(Duration silent_interval, FrameEnd end)
      : silent_interval_(silent_interval), complete_on_length_(end == FrameEnd::LengthOrSilence) {}

  // Bytes arrived at `t` (the arrival of the chunk's last byte).
  void feed(std::span<const uint8_t> bytes, TimePoint t);

  // The next complete frame at time `t`, if any.
  std::optional<Frame> poll(TimePoint t);

  // When poll() must next be called for a buffered frame to complete.
  std::optional<TimePoint> deadline() const;

  // Bytes dropped because a frame grew beyond any legal size.
  std::size_t overflowed() const noexcept { return overflowed_; }

 private:
  void close_frame();
  void try_complete_on_length();

  Duration silent_interval_;
  bool complete_on_length_;
  Bytes buffer_;
  std::size_t length_ = 0;     // bytes in the current frame, kept or not
  uint16_t overflow_crc_ = 0;  // running CRC once the frame outgrew the buffer
  TimePoint last_byte_{};
  std::deque<Frame> ready_;
  std::size_t overflowed_ = 0;
};

}  // namespace lec6::modbus
