#include "lec6/transport/recording_link.hpp"

#include <algorithm>

namespace lec6::transport {

RecordingLink::RecordingLink(client::Link& inner, LineTap tap)
    : inner_(inner), tap_(std::move(tap)) {
  timing_.baud = inner_.baud();
}

RecordingLink::~RecordingLink() {
  try {
    flush();
  } catch (...) {  // a tap that throws at exit loses its last group, nothing more
  }
}

void RecordingLink::flush() {
  if (pending_.bytes.empty()) return;
  LineChunk out = std::move(pending_);
  pending_ = LineChunk{};
  tap_(std::move(out));
}

// A line carries one frame at a time, so records follow each other: a frame
// starts no sooner than the one before it ended. On a real line that holds
// by itself. A port no wire paces (a pty; a twin with fast timing) hands a
// reply over, and takes the next query, sooner than their wire time: there
// the records keep the line's order on a line time of their own, stretched
// to the wire times, and a capture stays a capture (lec replay refused the
// out-of-order files `lec --record` wrote on such a port).
void RecordingLink::write(std::span<const uint8_t> bytes) {
  flush();
  const TimePoint start = std::max(inner_.clock().now(), line_free_);
  inner_.write(bytes);
  const TimePoint end = std::max(inner_.clock().now(), start + timing_.wire_time(bytes.size()));
  line_free_ = end;
  tap_(LineChunk{true, start, end, modbus::Bytes(bytes.begin(), bytes.end())});
}

void RecordingLink::received(std::span<const uint8_t> bytes) {
  if (bytes.empty()) return;
  // The bytes' wire time ends where they arrived.
  const Duration wire = timing_.wire_time(bytes.size());
  const TimePoint start = std::max(inner_.clock().now() - wire, line_free_);
  const TimePoint end = start + wire;
  line_free_ = end;
  if (!pending_.bytes.empty() && start - pending_.end > timing_.silent_interval()) flush();
  if (pending_.bytes.empty()) pending_.start = start;
  pending_.end = end;
  pending_.bytes.insert(pending_.bytes.end(), bytes.begin(), bytes.end());
}

std::size_t RecordingLink::read_some(std::span<uint8_t> buffer, TimePoint deadline) {
  const std::size_t n = inner_.read_some(buffer, deadline);
  received(buffer.first(n));
  return n;
}

std::size_t RecordingLink::read_some_exact(std::span<uint8_t> buffer, TimePoint deadline) {
  const std::size_t n = inner_.read_some_exact(buffer, deadline);
  received(buffer.first(n));
  return n;
}

void RecordingLink::discard_input() {
  inner_.discard_input();
}

}  // namespace lec6::transport
