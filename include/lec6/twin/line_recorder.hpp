#pragma once
// `lec --record FILE` and `lec serve --record FILE` (issue 24): every frame
// on a line, both directions, into a capture file (docs/capture-format.md).
// The tap (transport::RecordingLink) only appends a record to the writer's
// buffer; the file is written on the writer's own thread, so recording costs
// a transaction no time (BENCHMARKS.md, "Recording").
//
// Received bytes are a "reply" when they are one sound Modbus RTU frame
// (length and CRC), else "noise".
//
// Thread safety: the tap may be called from one thread at a time per link;
// several links may share one recorder (the writer locks).

#include <functional>
#include <memory>
#include <string>

#include "lec6/clock.hpp"
#include "lec6/transport/capture_file.hpp"
#include "lec6/transport/recording_link.hpp"

namespace lec6::twin {

class LineRecorder {
 public:
  // Creates `path` and writes the header (source: "record", "serve", …).
  // `clock` is the clock of the links it will record; its now() is t = 0.
  // Throws lec6::InvalidArgument naming the path when it cannot be created.
  LineRecorder(const std::string& path, std::string source, uint32_t baud, std::string port,
               const Clock& clock);
  ~LineRecorder();
  LineRecorder(const LineRecorder&) = delete;
  LineRecorder& operator=(const LineRecorder&) = delete;

  transport::LineTap tap();
  // Told once when writing the file fails (transport::CaptureWriter::on_error);
  // the tap keeps working (it drops what it cannot write).
  void on_error(std::function<void(const std::string&)> handler);
  // Writes out what is buffered (also done by the destructor).
  void flush();
  std::size_t records() const;
  const std::string& path() const;

 private:
  TimePoint origin_;
  std::unique_ptr<transport::CaptureWriter> writer_;
};

}  // namespace lec6::twin
