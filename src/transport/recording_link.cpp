#include "lec6/transport/recording_link.hpp"

#include <algorithm>

#include "lec6/modbus/crc.hpp"
#include "lec6/modbus/length.hpp"

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

namespace {

// Bytes that begin a reply frame and need more to complete it.
bool incomplete_frame(const modbus::Bytes& b) {
  const auto len = modbus::response_length(b);
  return len.status == modbus::FrameLength::Status::NeedMore ||
         (len.status == modbus::FrameLength::Status::Known && b.size() < len.bytes);
}

}  // namespace

void RecordingLink::flush() {
  for (auto& p : pieces_) tap_(std::move(p));  // never completed: as they arrived
  pieces_.clear();
  if (pending_.bytes.empty()) return;
  LineChunk out = std::move(pending_);
  pending_ = LineChunk{};
  tap_(std::move(out));
}

// The held pieces and the pending group: one sound frame → one group; more
// bytes than the frame, or a failed CRC → the pieces go as they arrived.
void RecordingLink::settle_pieces() {
  if (pieces_.empty()) return;
  modbus::Bytes all;
  for (const auto& p : pieces_) all.insert(all.end(), p.bytes.begin(), p.bytes.end());
  all.insert(all.end(), pending_.bytes.begin(), pending_.bytes.end());
  if (incomplete_frame(all)) return;  // wait for the rest
  const auto len = modbus::response_length(all);
  if (len.status == modbus::FrameLength::Status::Known && all.size() == len.bytes &&
      modbus::crc_ok(all)) {
    pending_.start = pieces_.front().start;
    pending_.bytes = std::move(all);
    pieces_.clear();
    return;
  }
  for (auto& p : pieces_) tap_(std::move(p));
  pieces_.clear();
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
  if (!pending_.bytes.empty() && start - pending_.end > timing_.silent_interval()) {
    modbus::Bytes so_far;
    for (const auto& p : pieces_) so_far.insert(so_far.end(), p.bytes.begin(), p.bytes.end());
    so_far.insert(so_far.end(), pending_.bytes.begin(), pending_.bytes.end());
    if (incomplete_frame(so_far)) {  // a reply cut by the adapter: hold it (issue 33)
      pieces_.push_back(std::move(pending_));
      pending_ = LineChunk{};
    } else {
      flush();
    }
  }
  if (pending_.bytes.empty()) pending_.start = start;
  pending_.end = end;
  pending_.bytes.insert(pending_.bytes.end(), bytes.begin(), bytes.end());
  settle_pieces();
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
