#include "lec6/twin/line_recorder.hpp"

#include <algorithm>

#include "lec6/version.hpp"

namespace lec6::twin {

LineRecorder::LineRecorder(const std::string& path, std::string source, uint32_t baud,
                           std::string port, const Clock& clock)
    : origin_(clock.now()) {
  modbus::CaptureHeader h;
  h.source = std::move(source);
  h.started_utc = modbus::format_capture_utc(std::chrono::system_clock::now());
  h.line.baud = baud;
  h.line.parity = 'N';  // lec opens serial ports 8N1
  h.port = std::move(port);
  h.tool = std::string("lec ") + LEC6_VERSION_STRING;
  writer_ = std::make_unique<transport::CaptureWriter>(path, h);
}

LineRecorder::~LineRecorder() {
  try {
    writer_->close();
  } catch (...) {  // reported by flush() when the caller wants to know
  }
}

transport::LineTap LineRecorder::tap() {
  return [this](transport::LineChunk&& c) {
    modbus::CaptureRecord r;
    r.t_us = std::chrono::duration_cast<std::chrono::microseconds>(c.start - origin_).count();
    r.end_us = std::max(
        r.t_us, std::chrono::duration_cast<std::chrono::microseconds>(c.end - origin_).count());
    if (r.t_us < 0) r.t_us = 0;
    if (r.end_us < r.t_us) r.end_us = r.t_us;
    if (c.sent) {
      r.dir = modbus::CaptureDir::Query;
    } else {
      r.dir =
          modbus::decode_response(c.bytes) ? modbus::CaptureDir::Reply : modbus::CaptureDir::Noise;
    }
    r.bytes = std::move(c.bytes);
    writer_->write(r);
  };
}

void LineRecorder::on_error(std::function<void(const std::string&)> handler) {
  writer_->on_error(std::move(handler));
}

void LineRecorder::flush() {
  writer_->flush();
}

std::size_t LineRecorder::records() const {
  return writer_->records_written();
}

const std::string& LineRecorder::path() const {
  return writer_->path();
}

}  // namespace lec6::twin
