#pragma once
// Capture files (docs/capture-format.md) on disk: read whole, or written as
// the traffic comes.
//
// Thread safety: read_capture_file shares nothing. A CaptureWriter may be
// written from several threads (write() takes a lock); its flushing runs on
// a thread of its own.

#include <condition_variable>
#include <functional>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "lec6/modbus/capture.hpp"

namespace lec6::transport {

// Reads and parses `path`. A missing or unreadable file throws
// lec6::InvalidArgument ("cannot read capture.jsonl: No such file or
// directory"); a malformed one modbus::CaptureError (file, line, byte offset).
modbus::Capture read_capture_file(const std::string& path);

// Keeps an earlier capture at `path` (issue 33: `lec serve --record` never
// truncates one): a non-empty file there is renamed to the first free
// `path.1`, `path.2`, …, and that name returned; nothing there (or an empty
// file): nullopt. A symlink `path` is left in place: the file it names is
// renamed beside itself (its own name .1, .2, …) and the new capture is
// written through the link. Throws lec6::InvalidArgument naming both paths when the
// rename fails. Tested in tests/transport/capture_rotate_test.cpp.
std::optional<std::string> keep_earlier_capture(const std::string& path);

// Writes a capture as it happens: the header at construction, then one line
// per write(). write() only appends to a buffer in memory (no system call,
// so recording never costs a transaction time); a background thread writes
// the buffer out at least every `flush_interval`, and flush()/close()/the
// destructor write out everything before returning.
class CaptureWriter {
 public:
  static constexpr std::size_t kMaxPendingBytes = 4u << 20;
  // Creates (or truncates) `path` and writes the header. Throws
  // lec6::InvalidArgument naming the path if it cannot be created.
  explicit CaptureWriter(const std::string& path, const modbus::CaptureHeader& header,
                         std::chrono::milliseconds flush_interval = std::chrono::milliseconds(200));
  ~CaptureWriter();
  CaptureWriter(const CaptureWriter&) = delete;
  CaptureWriter& operator=(const CaptureWriter&) = delete;

  // Never throws for a failed write of the file: after one, records are
  // dropped (counted), the error is kept for flush()/close() and told once to
  // on_error. Throws only when the capture is already closed.
  void write(const modbus::CaptureRecord& record);
  // Called once, on the writer's thread (or the one flushing), with "cannot
  // write PATH: REASON" when writing the file first fails (a full disk, an
  // I/O error): a daemon logs it and keeps working (tests/transport/
  // capture_file_test.cpp, tests/integration/serve_record_errors_test.sh).
  // Set before the first write.
  void on_error(std::function<void(const std::string&)> handler);
  // Records dropped after a failed write, or while more than
  // kMaxPendingBytes wait for a file that takes nothing (a stalled pipe).
  std::size_t records_dropped() const;

  // Writes out what is buffered now. Throws lec6::Error naming the path if
  // writing failed (here or earlier, on the background thread).
  void flush();
  // flush(), then closes the file; later writes are refused. Idempotent.
  void close();

  const std::string& path() const noexcept { return path_; }
  std::size_t records_written() const;

 private:
  void run();
  void write_out(std::unique_lock<std::mutex>& lock);
  void throw_if_failed() const;

  std::string path_;
  int fd_ = -1;
  std::chrono::milliseconds flush_interval_;
  mutable std::mutex mutex_;
  std::condition_variable wake_;
  std::condition_variable written_;
  std::string pending_;
  uint64_t file_bytes_ = 0;  // written to the file so far (whole records)
  bool regular_ = true;      // a regular file (else a pipe, a device: written non-blocking)
  std::atomic<bool> abandon_{false};  // close() gave up on a file that takes nothing
  bool writing_ = false;
  bool stop_ = false;
  bool closed_ = false;
  std::string error_;
  std::size_t records_ = 0;
  std::size_t dropped_ = 0;
  std::function<void(const std::string&)> on_error_;
  std::thread thread_;
};

}  // namespace lec6::transport
