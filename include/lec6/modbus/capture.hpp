#pragma once
// The one capture format of lec6 (docs/capture-format.md): JSON Lines, a
// header line then one record per frame (or burst of noise) seen on a line,
// with microsecond times. Written by `lec sniff`, `lec --record`,
// `lec serve --record` and the twin's tap; read by `lec sniff --read`,
// `lec replay` and `lec sim --calibrate`.
//
// Sans-I/O: text in, values out (and back). File I/O lives in
// lec6/transport/capture_file.hpp.
//
// Thread safety: value types and pure functions.

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "lec6/error.hpp"
#include "lec6/modbus/pdu.hpp"

namespace lec6::modbus {

inline constexpr std::string_view kCaptureFormat = "lec6-capture";
inline constexpr int kCaptureVersion = 1;

// The line's settings as the recorder had them.
struct CaptureLine {
  uint32_t baud = 38400;
  char parity = 'E';  // 'E', 'O' or 'N'
  uint8_t data_bits = 8;
  uint8_t stop_bits = 1;
};

struct CaptureHeader {
  int version = kCaptureVersion;
  std::string source;       // "sniff", "record", "serve", "tap" (free text)
  std::string started_utc;  // "2026-11-24T19:00:00.123456Z": the zero of every t_us
  CaptureLine line;
  std::string port;  // the port recorded, as the user named it
  std::string tool;  // "lec 0.1.0"
};

enum class CaptureDir : uint8_t {
  Query,    // master → controller
  Reply,    // controller → master
  Noise,    // bytes that no frame confirms
  Unknown,  // not (yet) attributed
};

// "query", "reply", "noise", "unknown".
std::string_view capture_dir_name(CaptureDir) noexcept;

struct CaptureRecord {
  int64_t t_us = 0;    // µs from started_utc to the record's first byte
  int64_t end_us = 0;  // µs from started_utc to its last byte (≥ t_us)
  CaptureDir dir = CaptureDir::Unknown;
  Bytes bytes;
  std::string note;  // optional; empty: not written
};

struct Capture {
  CaptureHeader header;
  std::vector<CaptureRecord> records;
};

// A capture that cannot be read. what() names the file, the line (1-based)
// and the byte offset of that line's start in the file, then what is wrong:
// "capture.jsonl, line 17 (byte 1432): 'hex' has an odd number of digits".
class CaptureError : public InvalidArgument {
 public:
  CaptureError(std::string_view file_name, std::size_t line, std::size_t offset,
               std::string_view problem);
  std::size_t line() const noexcept { return line_; }
  std::size_t offset() const noexcept { return offset_; }

 private:
  std::size_t line_;
  std::size_t offset_;
};

// One JSON line each, ending in '\n'.
std::string encode_capture_header(const CaptureHeader&);
std::string encode_capture_record(const CaptureRecord&);

// Parses a whole capture. Unknown keys are ignored (forward compatibility
// within version 1); another "format", a "version" other than 1, a malformed
// line, records out of time order and a file cut in the middle of its last
// line throw CaptureError naming `file_name`.
Capture parse_capture(std::string_view text, std::string_view file_name);

// "2026-11-24T19:00:00.123456Z" for a header's started_utc.
std::string format_capture_utc(std::chrono::system_clock::time_point t);

}  // namespace lec6::modbus
