#pragma once
// The sniffer's harness (`lec sniff`, modbus::Sniffer), header-only like the
// others (fuzz/harness.hpp): the libFuzzer program fuzz/fuzz_sniff.cpp and the
// regression test (tests/modbus/fuzz_regression_test.cpp) run the same code.
//
// Input: [ctl][bytes a second adapter hears]. ctl seeds the chunk sizes and
// the gaps between chunks (some longer than the sniffer's idle gap) and picks
// the baud (bits 0-1). The same bytes are also read as a capture file
// (modbus::parse_capture), which must answer with a capture or a
// CaptureError naming the file, nothing else.
//
// Properties (what `lec sniff` promises its user):
//   - nothing is dropped silently: the bytes of the Query, Reply and Noise
//     events, in event order, are the input, byte for byte (line order);
//   - a Query or Reply event is a frame whose CRC holds;
//   - a Reply paired with a query carries the query's ID; a NoReply repeats
//     a query that was reported;
//   - the statistics agree with the events (frames, noise bytes);
//   - after advance(t), deadline() is later than t (or none): a caller that
//     sleeps until the deadline never spins.

#include <cstddef>
#include <cstdint>
#include <span>
#include <string_view>

#include "harness.hpp"
#include "lec6/modbus/capture.hpp"
#include "lec6/modbus/sniffer.hpp"

namespace lec6::fuzz {

inline void sniff_one(const uint8_t* data, std::size_t size) {
  if (size < 1) return;
  const uint8_t ctl = data[0];
  const std::span<const uint8_t> stream(data + 1, size - 1);

  static constexpr uint32_t kBauds[] = {38400, 9600, 115200, 230400};
  modbus::SnifferOptions options;
  options.timing.baud = kBauds[ctl & 3];
  modbus::Sniffer sniffer(options);
  Rng rng(ctl);
  TimePoint t = TimePoint{} + std::chrono::seconds(1);
  std::vector<modbus::SniffEvent> events;
  auto take = [&] {
    for (auto& e : sniffer.take()) events.push_back(std::move(e));
  };
  std::size_t at = 0;
  while (at < stream.size()) {
    const std::size_t n = std::min(stream.size() - at, 1 + rng.below(24));
    sniffer.feed(stream.subspan(at, n), t);
    at += n;
    // Gaps: none, a character or so, a frame's silence, beyond the idle gap.
    static constexpr int64_t kGapUs[] = {0, 300, 2000, 20000, 400000};
    t += std::chrono::microseconds(kGapUs[rng.below(5)]);
    while (auto d = sniffer.deadline()) {
      if (*d > t) break;
      sniffer.advance(t);
      take();
      const auto after = sniffer.deadline();
      check(!after || *after > t,
            "deadline() is still due after advance(): a caller's read loop would spin");
    }
    take();
  }
  sniffer.finish(t + std::chrono::seconds(5));
  take();

  Bytes heard;
  uint64_t frames = 0, noise_bytes = 0;
  std::vector<Bytes> queries;
  for (const auto& e : events) {
    switch (e.kind) {
      case modbus::SniffKind::Query:
      case modbus::SniffKind::Reply:
        check(e.bytes.size() >= 4 && modbus::crc_ok(e.bytes),
              "the sniffer reported a frame whose CRC fails");
        ++frames;
        if (e.kind == modbus::SniffKind::Query) queries.push_back(e.bytes);
        if (e.kind == modbus::SniffKind::Reply && !e.query.empty())
          check(e.query[0] == e.bytes[0], "a reply paired with a query to another ID");
        heard.insert(heard.end(), e.bytes.begin(), e.bytes.end());
        break;
      case modbus::SniffKind::Noise:
        check(!e.bytes.empty(), "an empty noise burst");
        noise_bytes += e.bytes.size();
        heard.insert(heard.end(), e.bytes.begin(), e.bytes.end());
        break;
      case modbus::SniffKind::NoReply:
        check(std::find(queries.begin(), queries.end(), e.bytes) != queries.end(),
              "no reply to a query that was never reported");
        break;
    }
  }
  check(heard == Bytes(stream.begin(), stream.end()),
        "the sniffer's frames and noise are not the bytes it heard, in order");
  check(sniffer.stats().frames == frames, "stats().frames disagrees with the events");
  check(sniffer.stats().noise_bytes == noise_bytes,
        "stats().noise_bytes disagrees with the events");

  // The same bytes as a capture file: a capture, or an error naming the file.
  const std::string_view text(reinterpret_cast<const char*>(stream.data()), stream.size());
  try {
    (void)modbus::parse_capture(text, "fuzz.jsonl");
  } catch (const modbus::CaptureError& e) {
    check(std::string_view(e.what()).find("fuzz.jsonl") != std::string_view::npos,
          "a capture error that does not name the file");
  }
}

}  // namespace lec6::fuzz
