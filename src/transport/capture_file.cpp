// Capture files on disk: the reader, and the writer that never makes its
// caller wait for the disk.

#include "lec6/transport/capture_file.hpp"

#include <fcntl.h>
#include <poll.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>

#include <fmt/format.h>

#include <algorithm>

#include "lec6/transport/file.hpp"

namespace lec6::transport {

modbus::Capture read_capture_file(const std::string& path) {
  auto text = read_file(path);
  if (!text) throw InvalidArgument(text.error());
  return modbus::parse_capture(*text, path);
}

std::optional<std::string> keep_earlier_capture(const std::string& path) {
  struct stat st {};
  // Only a regular file is an earlier capture (not /dev/full, a FIFO, a tty).
  if (::stat(path.c_str(), &st) != 0 || !S_ISREG(st.st_mode) || st.st_size == 0)
    return std::nullopt;
  // A symlink (latest.jsonl -> /data/line-7.jsonl) stays: the file it names
  // is the capture, moved aside beside itself, and the new one is written
  // through the link (open follows it). Renaming the link itself left the
  // user's link gone and a plain file in its place.
  const std::string file = file_behind(path).string();
  for (unsigned n = 1;; ++n) {
    const std::string kept = fmt::format("{}.{}", file, n);
    struct stat other {};
    if (::lstat(kept.c_str(), &other) == 0) continue;
    if (::rename(file.c_str(), kept.c_str()) != 0) {
      throw InvalidArgument(fmt::format(
          "cannot keep the earlier capture {} as {}: {}; it is not overwritten: move or remove "
          "it first, or record to another file",
          file, kept, std::strerror(errno)));
    }
    return kept;
  }
}

CaptureWriter::CaptureWriter(const std::string& path, const modbus::CaptureHeader& header,
                             std::chrono::milliseconds flush_interval)
    : path_(path), flush_interval_(flush_interval) {
  // A FIFO is opened without blocking: with no reader yet, open() would
  // wait for one for ever (lec serve --record FIFO hung at start).
  struct stat before {};
  const bool fifo = ::stat(path.c_str(), &before) == 0 && S_ISFIFO(before.st_mode);
  fd_ = ::open(path.c_str(), O_WRONLY | O_CREAT | O_CLOEXEC | (fifo ? O_NONBLOCK : O_TRUNC), 0666);
  if (fd_ < 0 && fifo && errno == ENXIO)
    throw InvalidArgument(fmt::format(
        "cannot record to {}: it is a FIFO and nothing reads it yet; start its reader first",
        path));
  if (fd_ < 0)
    throw InvalidArgument(fmt::format("cannot create {}: {}", path, std::strerror(errno)));
  // A pipe or a device is written without blocking, so that a reader that
  // stops reading never holds close() (and a daemon's shutdown) for ever.
  struct stat st {};
  regular_ = ::fstat(fd_, &st) == 0 && S_ISREG(st.st_mode);
  if (!regular_) ::fcntl(fd_, F_SETFL, ::fcntl(fd_, F_GETFL) | O_NONBLOCK);
  pending_ = modbus::encode_capture_header(header);
  thread_ = std::thread([this] { run(); });
}

CaptureWriter::~CaptureWriter() {
  try {
    close();
  } catch (...) {  // a destructor cannot report it; close() could have
  }
}

void CaptureWriter::write(const modbus::CaptureRecord& record) {
  std::string line = modbus::encode_capture_record(record);
  std::lock_guard lock(mutex_);
  if (closed_ || stop_) throw Error(fmt::format("{}: the capture is already closed", path_));
  if (!error_.empty()) {  // the file failed: nothing more is kept (memory stays bounded)
    ++dropped_;
    return;
  }
  if (pending_.size() + line.size() > kMaxPendingBytes) {  // the file takes nothing: bounded
    ++dropped_;
    return;
  }
  pending_ += line;
  ++records_;
}

void CaptureWriter::on_error(std::function<void(const std::string&)> handler) {
  std::lock_guard lock(mutex_);
  on_error_ = std::move(handler);
}

std::size_t CaptureWriter::records_dropped() const {
  std::lock_guard lock(mutex_);
  return dropped_;
}

std::size_t CaptureWriter::records_written() const {
  std::lock_guard lock(mutex_);
  return records_;
}

// Called with the lock held; releases it while the bytes go to the file.
void CaptureWriter::write_out(std::unique_lock<std::mutex>& lock) {
  std::string chunk;
  chunk.swap(pending_);
  writing_ = true;
  lock.unlock();
  std::string failure;
  std::size_t done = 0;
  while (done < chunk.size()) {
    const ssize_t n = ::write(fd_, chunk.data() + done, chunk.size() - done);
    if (n < 0) {
      if (errno == EINTR) continue;
      if (errno == EAGAIN && !abandon_) {  // a pipe that is full: wait for room
        pollfd p{fd_, POLLOUT, 0};
        ::poll(&p, 1, 100);
        continue;
      }
      failure = fmt::format("cannot write {}: {}", path_,
                            errno == EAGAIN ? "it takes nothing (stalled)" : std::strerror(errno));
      break;
    }
    done += static_cast<std::size_t>(n);
  }
  // Whole records only: a write cut short (a full disk) is taken back to the
  // last complete line, so the capture stays readable up to the failure.
  std::size_t whole = done;
  if (!failure.empty()) {
    const auto nl = chunk.rfind('\n', done == 0 ? std::string::npos : done - 1);
    whole = (done == 0 || nl == std::string::npos) ? 0 : nl + 1;
    if (whole != done && regular_) {
      if (::ftruncate(fd_, static_cast<off_t>(file_bytes_ + whole)) == 0) {
        ::lseek(fd_, static_cast<off_t>(file_bytes_ + whole), SEEK_SET);
      }
    }
  }
  file_bytes_ += whole;
  lock.lock();
  writing_ = false;
  const bool first_failure = !failure.empty() && error_.empty();
  if (first_failure) {
    error_ = failure;
    dropped_ += static_cast<std::size_t>(
        std::count(chunk.begin() + static_cast<std::ptrdiff_t>(whole), chunk.end(), '\n'));
  }
  written_.notify_all();
  if (first_failure && on_error_) {
    const auto handler = on_error_;
    lock.unlock();
    handler(failure);
    lock.lock();
  }
}

void CaptureWriter::run() {
  std::unique_lock lock(mutex_);
  while (!stop_) {
    wake_.wait_for(lock, flush_interval_, [this] { return stop_; });
    if (!pending_.empty() && !writing_) write_out(lock);
  }
}

void CaptureWriter::throw_if_failed() const {
  if (!error_.empty()) throw Error(error_);
}

void CaptureWriter::flush() {
  std::unique_lock lock(mutex_);
  while (writing_ || !pending_.empty()) {
    if (writing_) {
      written_.wait(lock);
    } else if (fd_ >= 0) {
      write_out(lock);
    } else {
      break;
    }
  }
  throw_if_failed();
}

void CaptureWriter::close() {
  {
    std::lock_guard lock(mutex_);
    if (closed_) {
      throw_if_failed();
      return;
    }
    stop_ = true;
  }
  wake_.notify_all();
  {
    // A file that takes nothing (a reader that stopped reading) is given up
    // after 2 s: the records still waiting are dropped, close() ends.
    std::unique_lock lock(mutex_);
    if (!written_.wait_for(lock, std::chrono::seconds(2), [this] { return !writing_; }))
      abandon_ = true;
  }
  if (thread_.joinable()) thread_.join();
  {
    std::unique_lock lock(mutex_);
    if (!pending_.empty()) write_out(lock);
    if (fd_ >= 0 && ::close(fd_) != 0 && error_.empty())
      error_ = fmt::format("cannot write {}: {}", path_, std::strerror(errno));
    fd_ = -1;
    closed_ = true;
    throw_if_failed();
  }
}

}  // namespace lec6::transport
