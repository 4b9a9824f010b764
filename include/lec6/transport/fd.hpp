#pragma once
// Small POSIX helpers shared by the transports and by event loops that poll
// their descriptors (the twin's server): an owning file descriptor, errno text,
// and a deadline-bounded poll that never busy-waits.
//
// Thread safety: UniqueFd is used by one thread at a time; the functions share nothing.

#include <poll.h>

#include <functional>
#include <span>
#include <string>

#include <sys/types.h>
#include <utility>

#include "lec6/clock.hpp"

namespace lec6::transport {

// Owns one file descriptor; closes it on destruction. Move-only.
class UniqueFd {
 public:
  UniqueFd() = default;
  explicit UniqueFd(int fd) noexcept : fd_(fd) {}
  UniqueFd(UniqueFd&& other) noexcept : fd_(other.release()) {}
  UniqueFd& operator=(UniqueFd&& other) noexcept {
    if (this != &other) reset(other.release());
    return *this;
  }
  UniqueFd(const UniqueFd&) = delete;
  UniqueFd& operator=(const UniqueFd&) = delete;
  ~UniqueFd() { reset(); }

  int get() const noexcept { return fd_; }
  bool valid() const noexcept { return fd_ >= 0; }
  explicit operator bool() const noexcept { return valid(); }
  int release() noexcept { return std::exchange(fd_, -1); }
  // Closes the current descriptor (if any) and takes `fd`.
  void reset(int fd = -1) noexcept;

 private:
  int fd_ = -1;
};

// strerror for `err`, thread-safe.
std::string errno_text(int err);

// Waits until `fd` reports one of `events` (or an error/hang-up condition), or
// until `deadline` passes as read on `clock`. Returns the revents, or 0 once
// the deadline has passed (never before it). A deadline already in the past
// still checks the descriptor once. Retries on EINTR; throws lec6::SystemError
// if poll itself fails.
short poll_until(int fd, short events, TimePoint deadline, const Clock& clock);

// What read_until got: bytes (> 0), or none because the deadline passed
// (closed false) or because the other end is gone (closed true: end of file,
// a hang-up).
struct ReadSome {
  std::size_t bytes = 0;
  bool closed = false;
};

// Reads what is there from a non-blocking descriptor, waiting for POLLIN up to
// `deadline` (a spurious wake-up waits again). `get(data, size)` makes one
// attempt (read(2) or recv(2)) and returns its result. Errors other than
// EINTR/EAGAIN throw lec6::SystemError with the errno and the call ("poll",
// "read"), for the caller to word. The one read loop of every byte link.
ReadSome read_until(int fd, std::span<uint8_t> buffer, TimePoint deadline, const Clock& clock,
                    const std::function<ssize_t(uint8_t*, std::size_t)>& get);

// Sets or clears O_NONBLOCK; returns false (errno set) on failure.
bool set_nonblocking(int fd, bool on = true);

// Writes every byte to a non-blocking descriptor, waiting for POLLOUT up to
// `deadline`. `put(data, size)` makes one attempt (write(2) or send(2)) and
// returns its result. Returns how many bytes went out: fewer than asked means
// the deadline passed. Errors other than EINTR/EAGAIN throw lec6::SystemError
// with the errno, for the caller to word.
std::size_t write_all(int fd, std::span<const uint8_t> bytes, TimePoint deadline,
                      const Clock& clock,
                      const std::function<ssize_t(const uint8_t*, std::size_t)>& put);

}  // namespace lec6::transport
