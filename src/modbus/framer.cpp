#include "lec6/modbus/framer.hpp"

#include <algorithm>

#include "lec6/modbus/crc.hpp"
#include "lec6/modbus/length.hpp"

namespace lec6::modbus {

// ---- ClientFramer -----------------------------------------------------------

void ClientFramer::expect(const Expectation& e) {
  discarded_ = 0;
  crc_failures_ = 0;
  last_discard_ = Discard::None;
  buffer_.clear();
  frame_length_ = 0;
  expect_ = e;
}

void ClientFramer::expect(uint8_t id, const Request& request) {
  expect(Expectation{id, function_of(request), expected_response_length(request)});
}

ClientFramer::Status ClientFramer::feed(std::span<const uint8_t> bytes) {
  if (frame_length_) {
    // A completed frame is still buffered: the caller has moved on; drop it.
    buffer_.erase(buffer_.begin(), buffer_.begin() + static_cast<std::ptrdiff_t>(frame_length_));
    frame_length_ = 0;
  }
  buffer_.insert(buffer_.end(), bytes.begin(), bytes.end());
  return scan();
}

void ClientFramer::drop_front(Discard why) {
  buffer_.erase(buffer_.begin());
  ++discarded_;
  last_discard_ = std::max(last_discard_, why);
}

bool ClientFramer::is_read() const noexcept {
  return expect_.function == FunctionCode::ReadCoils ||
         expect_.function == FunctionCode::ReadInputs ||
         expect_.function == FunctionCode::ReadRegisters;
}

ClientFramer::Status ClientFramer::scan() {
  const uint8_t fc = static_cast<uint8_t>(expect_.function);
  while (!buffer_.empty()) {
    if (buffer_[0] != expect_.id) {
      drop_front(Discard::WrongId);
      continue;
    }
    if (buffer_.size() < 2) return Status::Incomplete;
    const bool exception = buffer_[1] == (fc | kExceptionFlag);
    if (buffer_[1] != fc && !exception) {
      drop_front(Discard::WrongFunction);
      continue;
    }
    // Reads: the byte count must be the one the request implies, so a garbage
    // byte count cannot make us wait for a frame that will never come.
    if (!exception && is_read() && buffer_.size() >= 3 &&
        buffer_[2] + 5u != expect_.normal_length) {
      drop_front(Discard::WrongLength);
      continue;
    }
    const std::size_t length = exception ? kExceptionLength : expect_.normal_length;
    if (buffer_.size() < length) return Status::Incomplete;
    if (!crc_ok(std::span<const uint8_t>(buffer_.data(), length))) {
      ++crc_failures_;
      drop_front(Discard::BadCrc);
      continue;
    }
    frame_length_ = length;
    return Status::Complete;
  }
  return Status::Incomplete;
}

std::size_t ClientFramer::bytes_wanted() const noexcept {
  if (frame_length_) return 0;
  if (buffer_.size() < 2) return expect_.normal_length - buffer_.size();
  const bool exception = buffer_[1] & kExceptionFlag;
  const std::size_t length = exception ? kExceptionLength : expect_.normal_length;
  return length > buffer_.size() ? length - buffer_.size() : 1;
}

std::string_view discard_name(ClientFramer::Discard d) noexcept {
  switch (d) {
    case ClientFramer::Discard::None:
      return "none";
    case ClientFramer::Discard::WrongId:
      return "bytes from another ID or noise";
    case ClientFramer::Discard::WrongFunction:
      return "unexpected function code";
    case ClientFramer::Discard::WrongLength:
      return "byte count does not match the request";
    case ClientFramer::Discard::BadCrc:
      return "CRC mismatch";
  }
  return "?";
}

// ---- DeviceFramer -----------------------------------------------------------

void DeviceFramer::close_frame() {
  if (buffer_.empty()) return;
  const bool too_long = length_ > kMaxAdu;
  const bool dropped = length_ > buffer_.size();
  const bool long_ok = too_long && (dropped ? overflow_crc_ : crc16(buffer_)) == 0;
  ready_.push_back(Frame{std::move(buffer_), last_byte_, length_, long_ok});
  buffer_.clear();
  length_ = 0;
}

void DeviceFramer::try_complete_on_length() {
  for (;;) {
    const FrameLength len = request_length(buffer_);
    if (len.status != FrameLength::Status::Known || buffer_.size() < len.bytes) return;
    if (!crc_ok(std::span<const uint8_t>(buffer_.data(), len.bytes))) return;
    Bytes rest(buffer_.begin() + static_cast<std::ptrdiff_t>(len.bytes), buffer_.end());
    buffer_.resize(len.bytes);
    length_ = len.bytes;
    close_frame();
    length_ = rest.size();
    buffer_ = std::move(rest);
  }
}

void DeviceFramer::feed(std::span<const uint8_t> bytes, TimePoint t) {
  if (!buffer_.empty() && t - last_byte_ >= silent_interval_) close_frame();
  // No legal frame is longer than kMaxAdu; keep one byte beyond so the frame
  // still fails as too long, and drop the rest instead of growing without bound.
  // A running CRC over what is dropped still tells whether the whole frame
  // was sound (digest §3: data > 256 B gets exception 03, not silence).
  const std::size_t room = kMaxAdu + 1 > buffer_.size() ? kMaxAdu + 1 - buffer_.size() : 0;
  const std::size_t take = std::min(room, bytes.size());
  buffer_.insert(buffer_.end(), bytes.begin(), bytes.begin() + static_cast<std::ptrdiff_t>(take));
  if (take < bytes.size()) {
    if (length_ + take == buffer_.size()) overflow_crc_ = crc16(buffer_);  // first overflow
    overflow_crc_ = crc16_update(overflow_crc_, bytes.subspan(take));
  }
  length_ += bytes.size();
  overflowed_ += bytes.size() - take;
  last_byte_ = t;
  if (complete_on_length_) try_complete_on_length();
}

std::optional<DeviceFramer::Frame> DeviceFramer::poll(TimePoint t) {
  if (!buffer_.empty() && t - last_byte_ >= silent_interval_) close_frame();
  if (ready_.empty()) return std::nullopt;
  Frame f = std::move(ready_.front());
  ready_.pop_front();
  return f;
}

std::optional<TimePoint> DeviceFramer::deadline() const {
  if (!ready_.empty()) return last_byte_;
  if (buffer_.empty()) return std::nullopt;
  return last_byte_ + silent_interval_;
}

}  // namespace lec6::modbus
