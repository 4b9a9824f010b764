#pragma once
// A Link that tells a tap every byte that crosses it, both directions, with
// the time it crossed (issue 24: `lec --record`, `lec serve --record`).
//
// Sent bytes are one chunk per write (a query): start is when write() was
// called, end when it returned (at least start + wire time). Received bytes
// are grouped the way RTU delimits frames: chunks that follow each other
// within the silent interval (3.5 characters) are one group, handed to the
// tap when the next write starts, when a silence longer than that follows, or
// at flush()/destruction. A received chunk's first byte is dated back by its
// wire time from when read_some returned it. A reply whose bytes arrive in
// two (or more) USB chunks with a longer silence between them is still one
// group when together they make exactly one sound frame (its length from its
// head, its CRC): the pieces are held until the frame is complete, and handed
// over as they arrived when they are not one frame (issue 33; tested in
// tests/twin/recording_link_test.cpp). No frame starts before the one
// before it ended (a port no wire paces gets a line time stretched to the
// wire times: see recording_link.cpp).
//
// The tap runs in the transaction's path: it must only copy (e.g. append to
// a buffer that another thread writes out), never block on a file.
//
// Thread safety: as the wrapped Link (one thread at a time).

#include <functional>
#include <vector>

#include "lec6/client/link.hpp"
#include "lec6/modbus/pdu.hpp"
#include "lec6/modbus/timing.hpp"

namespace lec6::transport {

struct LineChunk {
  bool sent = false;  // true: the master sent it (a query); false: received
  TimePoint start;    // first byte on the line
  TimePoint end;      // last byte on the line
  modbus::Bytes bytes;
};
using LineTap = std::function<void(LineChunk&&)>;

class RecordingLink final : public client::Link {
 public:
  RecordingLink(client::Link& inner, LineTap tap);
  ~RecordingLink() override;
  RecordingLink(const RecordingLink&) = delete;
  RecordingLink& operator=(const RecordingLink&) = delete;

  void write(std::span<const uint8_t> bytes) override;
  std::size_t read_some(std::span<uint8_t> buffer, TimePoint deadline) override;
  std::size_t read_some_exact(std::span<uint8_t> buffer, TimePoint deadline) override;
  void discard_input() override;
  const Clock& clock() const override { return inner_.clock(); }
  uint32_t baud() const override { return inner_.baud(); }
  std::string describe() const override { return inner_.describe(); }

  // Hands the received bytes not yet handed over to the tap.
  void flush();

 private:
  void received(std::span<const uint8_t> bytes);

  client::Link& inner_;
  LineTap tap_;
  modbus::LineTiming timing_;
  TimePoint line_free_{};  // where the last frame's wire time ended
  LineChunk pending_;      // received, not yet handed over
  // Earlier groups the pending one may complete as one frame (see above).
  std::vector<LineChunk> pieces_;
  void settle_pieces();
};

}  // namespace lec6::transport
