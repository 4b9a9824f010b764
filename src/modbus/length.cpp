#include "lec6/modbus/length.hpp"

#include "lec6/modbus/pdu.hpp"

namespace lec6::modbus {

FrameLength request_length(std::span<const uint8_t> head) noexcept {
  if (head.size() < 2) return FrameLength::need_more();
  switch (head[1]) {
    case 0x01:
    case 0x02:
    case 0x03:
    case 0x05:
    case 0x08:
      return FrameLength::known(8);
    case 0x0F:
    case 0x10:
      // ID FC start(2) count(2) bytecount data CRC(2)
      if (head.size() < 7) return FrameLength::need_more();
      return FrameLength::known(9 + head[6]);
    default:
      return FrameLength::unknown();
  }
}

FrameLength response_length(std::span<const uint8_t> head) noexcept {
  if (head.size() < 2) return FrameLength::need_more();
  const uint8_t fc = head[1];
  if (fc & kExceptionFlag) return FrameLength::known(kExceptionLength);
  switch (fc) {
    case 0x01:
    case 0x02:
    case 0x03:
      // ID FC bytecount data CRC(2)
      if (head.size() < 3) return FrameLength::need_more();
      return FrameLength::known(5 + head[2]);
    case 0x05:
    case 0x08:
    case 0x0F:
    case 0x10:
      return FrameLength::known(8);
    default:
      return FrameLength::unknown();
  }
}

}  // namespace lec6::modbus
