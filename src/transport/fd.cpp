#include "lec6/transport/fd.hpp"
#include "lec6/error.hpp"

#include <fcntl.h>
#include <poll.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <ctime>
#include <system_error>

namespace lec6::transport {

void UniqueFd::reset(int fd) noexcept {
  if (fd_ >= 0 && fd_ != fd) {
    // Linux closes the descriptor even when close() reports EINTR: never retry.
    ::close(fd_);
  }
  fd_ = fd;
}

std::string errno_text(int err) {
  char buffer[256];
  // GNU strerror_r returns the message (possibly a static string, not buffer).
  const char* text = ::strerror_r(err, buffer, sizeof buffer);
  return text;
}

short poll_until(int fd, short events, TimePoint deadline, const Clock& clock) {
  pollfd pfd{};
  pfd.fd = fd;
  pfd.events = events;
  for (;;) {
    Duration remaining = deadline - clock.now();
    if (remaining < Duration::zero()) remaining = Duration::zero();
    timespec timeout{};
    timeout.tv_sec = static_cast<time_t>(remaining.count() / 1'000'000'000);
    timeout.tv_nsec = static_cast<long>(remaining.count() % 1'000'000'000);
    pfd.revents = 0;
    int r = ::ppoll(&pfd, 1, &timeout, nullptr);
    if (r > 0) return pfd.revents;
    if (r == 0) {
      // ppoll does not return early, but the steady clock and the poll timer
      // may round differently: only report a timeout once it is one.
      if (clock.now() >= deadline) return 0;
      continue;
    }
    if (errno == EINTR) continue;
    throw SystemError(errno, "poll");
  }
}

std::size_t write_all(int fd, std::span<const uint8_t> bytes, TimePoint deadline,
                      const Clock& clock,
                      const std::function<ssize_t(const uint8_t*, std::size_t)>& put) {
  std::size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = put(bytes.data() + done, bytes.size() - done);
    if (n > 0) {
      done += static_cast<std::size_t>(n);
      continue;
    }
    if (n < 0 && errno == EINTR) continue;
    if (n < 0 && errno != EAGAIN) throw SystemError(errno, "write");
    const short revents = poll_until(fd, POLLOUT, deadline, clock);
    if (revents == 0) return done;
    if (revents & POLLNVAL) throw SystemError(EBADF, "write");
  }
  return done;
}

ReadSome read_until(int fd, std::span<uint8_t> buffer, TimePoint deadline, const Clock& clock,
                    const std::function<ssize_t(uint8_t*, std::size_t)>& get) {
  if (buffer.empty()) return {};
  for (;;) {
    const short revents = poll_until(fd, POLLIN, deadline, clock);
    if (revents == 0) return {};
    if (revents & POLLNVAL) throw SystemError(EBADF, "read");
    const ssize_t n = get(buffer.data(), buffer.size());
    if (n > 0) return {static_cast<std::size_t>(n), false};
    if (n == 0) return {0, true};  // end of file: a hung-up tty, a closed connection
    const int err = errno;
    if (err != EAGAIN && err != EINTR) throw SystemError(err, "read");
    if (revents & (POLLHUP | POLLERR)) return {0, true};
    // a spurious wake-up: wait again
  }
}

bool set_nonblocking(int fd, bool on) {
  int flags = ::fcntl(fd, F_GETFL);
  if (flags < 0) return false;
  int wanted = on ? (flags | O_NONBLOCK) : (flags & ~O_NONBLOCK);
  if (wanted == flags) return true;
  return ::fcntl(fd, F_SETFL, wanted) == 0;
}

}  // namespace lec6::transport
