#include "lec6/modbus/mbap.hpp"

#include <fmt/format.h>

#include "wire_words.hpp"

namespace lec6::modbus {

Bytes encode_mbap(uint16_t transaction, uint8_t unit, std::span<const uint8_t> pdu) {
  Bytes out;
  out.reserve(kMbapHeaderSize + pdu.size());
  detail::put16(out, transaction);
  detail::put16(out, 0);
  detail::put16(out, static_cast<uint16_t>(1 + pdu.size()));
  out.push_back(unit);
  out.insert(out.end(), pdu.begin(), pdu.end());
  return out;
}

MbapFramer::Status MbapFramer::feed(std::span<const uint8_t> bytes) {
  if (broken_) return Status::Broken;
  buffer_.insert(buffer_.end(), bytes.begin(), bytes.end());
  // Judge a header as soon as it is in: a lying length must not make the
  // connection wait forever for bytes that will never come.
  if (buffer_.size() >= kMbapHeaderSize && !check_header()) return Status::Broken;
  return ready_status();
}

// Checks the header at the front of the buffer (7 bytes are there).
bool MbapFramer::check_header() {
  const uint16_t protocol = detail::get16(buffer_, 2);
  const uint16_t length = detail::get16(buffer_, 4);
  if (protocol != 0) {
    error_ = fmt::format(
        "protocol id {} in the MBAP header (Modbus TCP uses 0): not a Modbus TCP peer{}", protocol,
        buffer_[0] != 0 || buffer_[1] != 0 ? "" : ", or RTU framing sent to a Modbus TCP port");
    broken_ = true;
  } else if (length < 2 || length > 1 + kMaxMbapPdu) {
    error_ = fmt::format(
        "MBAP length {}: a Modbus TCP frame carries 2 to {} bytes after the length field", length,
        1 + kMaxMbapPdu);
    broken_ = true;
  }
  return !broken_;
}

MbapFramer::Status MbapFramer::ready_status() const noexcept {
  if (buffer_.size() < kMbapHeaderSize) return Status::Incomplete;
  const std::size_t total = 6 + detail::get16(buffer_, 4);
  return buffer_.size() >= total ? Status::Complete : Status::Incomplete;
}

std::optional<MbapAdu> MbapFramer::next() {
  if (broken_ || buffer_.size() < kMbapHeaderSize || !check_header()) return std::nullopt;
  const uint16_t length = detail::get16(buffer_, 4);
  const std::size_t total = 6 + std::size_t{length};
  if (buffer_.size() < total) return std::nullopt;
  MbapAdu adu;
  adu.header = {detail::get16(buffer_, 0), 0, length, buffer_[6]};
  adu.pdu.assign(buffer_.begin() + kMbapHeaderSize,
                 buffer_.begin() + static_cast<std::ptrdiff_t>(total));
  buffer_.erase(buffer_.begin(), buffer_.begin() + static_cast<std::ptrdiff_t>(total));
  if (buffer_.size() >= kMbapHeaderSize) check_header();
  return adu;
}

}  // namespace lec6::modbus
