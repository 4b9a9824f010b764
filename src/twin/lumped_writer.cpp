#include "twin/lumped_writer.hpp"

#include <unistd.h>

#include <cerrno>

namespace lec6::twin {

LumpedWriter::LumpedWriter(int fd, Duration latency, Duration char_time, TimePoint origin)
    : fd_(fd), char_time_(char_time), usb_(latency, sim::UsbLatency::kFtdiPacketBytes, origin) {}

void LumpedWriter::put(std::span<const uint8_t> bytes, TimePoint last_byte) {
  if (bytes.empty()) return;
  if (usb_.latency() == Duration::zero()) {
    staged_.emplace(last_byte, modbus::Bytes(bytes.begin(), bytes.end()));
    return;
  }
  const auto n = static_cast<int64_t>(bytes.size());
  for (int64_t i = 0; i < n; ++i) {
    staged_.emplace(last_byte - char_time_ * (n - 1 - i),
                    modbus::Bytes{bytes[static_cast<std::size_t>(i)]});
  }
}

bool LumpedWriter::flush(TimePoint now) {
  while (!staged_.empty() && staged_.begin()->first <= now) {
    auto node = staged_.extract(staged_.begin());
    usb_.push(node.mapped(), node.key());
  }
  modbus::Bytes out;
  for (auto& d : usb_.take(now)) out.insert(out.end(), d.bytes.begin(), d.bytes.end());
  std::size_t done = 0;
  while (done < out.size()) {
    const ssize_t w = ::write(fd_, out.data() + done, out.size() - done);
    if (w > 0) {
      done += static_cast<std::size_t>(w);
      continue;
    }
    if (w < 0 && errno == EINTR) continue;
    dropped_ += out.size() - done;
    return false;
  }
  return true;
}

std::optional<TimePoint> LumpedWriter::deadline() const {
  std::optional<TimePoint> d = usb_.next_delivery();
  if (!staged_.empty()) {
    // With a latency timer nothing goes out before the tick after the byte.
    const TimePoint first = staged_.begin()->first;
    const TimePoint due = usb_.latency() == Duration::zero() ? first : usb_.tick_after(first);
    if (!d || due < *d) d = due;
  }
  return d;
}

}  // namespace lec6::twin
