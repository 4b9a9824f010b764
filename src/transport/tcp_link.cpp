#include "lec6/transport/tcp_link.hpp"
#include "lec6/error.hpp"

#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <memory>
#include <system_error>

#include <fmt/format.h>

namespace lec6::transport {

namespace {

using client::LinkError;
using client::LinkErrorKind;

bool connection_gone(int err) {
  return err == ECONNRESET || err == EPIPE || err == ENOTCONN || err == ETIMEDOUT ||
         err == ECONNABORTED || err == EHOSTUNREACH || err == ENETUNREACH || err == ENETDOWN;
}

std::string host_in_url(const std::string& host) {
  return host.find(':') != std::string::npos ? "[" + host + "]" : host;
}

}  // namespace

TcpLink::TcpLink(std::string host, uint16_t port, TcpOptions options)
    : host_(std::move(host)), port_(port), options_(options) {
  auto unavailable = [this](const std::string& why) {
    throw LinkError(LinkErrorKind::PortUnavailable,
                    fmt::format("cannot connect to {}: {}", url(), why));
  };
  if (options_.baud == 0) throw InvalidArgument("TcpLink: baud must not be 0");

  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_STREAM;
  hints.ai_protocol = IPPROTO_TCP;
  hints.ai_flags = AI_NUMERICSERV;
  addrinfo* found = nullptr;
  const std::string service = std::to_string(port_);
  if (int err = ::getaddrinfo(host_.c_str(), service.c_str(), &hints, &found); err != 0) {
    unavailable(err == EAI_SYSTEM ? errno_text(errno) : std::string(::gai_strerror(err)));
  }
  std::unique_ptr<addrinfo, void (*)(addrinfo*)> list(found, ::freeaddrinfo);

  const TimePoint deadline = clock_.now() + options_.connect_timeout;
  std::string last_error = "no address";
  for (const addrinfo* ai = list.get(); ai != nullptr; ai = ai->ai_next) {
    UniqueFd fd(
        ::socket(ai->ai_family, ai->ai_socktype | SOCK_NONBLOCK | SOCK_CLOEXEC, ai->ai_protocol));
    if (!fd) {
      last_error = errno_text(errno);
      continue;
    }
    int err = 0;
    if (::connect(fd.get(), ai->ai_addr, ai->ai_addrlen) != 0) {
      err = errno;
      if (err == EINPROGRESS || err == EINTR) {
        short revents = 0;
        try {
          revents = poll_until(fd.get(), POLLOUT, deadline, clock_);
        } catch (const SystemError& e) {
          unavailable(e.what());
        }
        if (revents == 0) {
          last_error = fmt::format("no answer within {:.0f} ms", to_ms(options_.connect_timeout));
          continue;
        }
        socklen_t len = sizeof err;
        if (::getsockopt(fd.get(), SOL_SOCKET, SO_ERROR, &err, &len) != 0) err = errno;
      }
    }
    if (err != 0) {
      last_error = errno_text(err);
      continue;
    }
    const int one = 1;
    ::setsockopt(fd.get(), IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
    fd_ = std::move(fd);
    return;
  }
  unavailable(last_error);
}

std::string TcpLink::url() const {
  return fmt::format("{}://{}:{}", options_.scheme, host_in_url(host_), port_);
}

std::string TcpLink::describe() const {
  return fmt::format("{} @ {}", url(), options_.baud);
}

void TcpLink::fail(const char* operation, int err) const {
  if (connection_gone(err)) {
    throw LinkError(LinkErrorKind::PortLost, fmt::format("the connection to {} went away ({}: {})",
                                                         url(), operation, errno_text(err)));
  }
  throw LinkError(LinkErrorKind::Io,
                  fmt::format("{}: {} failed: {}", url(), operation, errno_text(err)));
}

void TcpLink::write(std::span<const uint8_t> bytes) {
  const int fd = fd_.get();
  // Frames are small; only a peer that stopped reading can make us wait.
  const TimePoint deadline = clock_.now() + std::chrono::seconds(5);
  std::size_t done = 0;
  try {
    done = write_all(fd, bytes, deadline, clock_, [fd](const uint8_t* p, std::size_t n) {
      return ::send(fd, p, n, MSG_NOSIGNAL);
    });
  } catch (const SystemError& e) {
    fail("write", e.code().value());
  }
  if (done < bytes.size()) {
    throw LinkError(LinkErrorKind::Io, fmt::format("{}: write timed out ({} of {} bytes sent)",
                                                   url(), done, bytes.size()));
  }
}

std::size_t TcpLink::read_some(std::span<uint8_t> buffer, TimePoint deadline) {
  if (buffer.empty()) return 0;
  const int fd = fd_.get();
  for (;;) {
    short revents = 0;
    try {
      revents = poll_until(fd, POLLIN, deadline, clock_);
    } catch (const SystemError& e) {
      fail("poll", e.code().value());
    }
    if (revents == 0) return 0;
    const ssize_t n = ::recv(fd, buffer.data(), buffer.size(), 0);
    if (n > 0) return static_cast<std::size_t>(n);
    if (n == 0) {
      throw LinkError(LinkErrorKind::PortLost,
                      fmt::format("the connection to {} was closed by the other end", url()));
    }
    const int err = errno;
    if (err == EAGAIN || err == EINTR) continue;
    fail("read", err);
  }
}

void TcpLink::discard_input() {
  uint8_t scratch[512];
  for (;;) {
    const ssize_t n = ::recv(fd_.get(), scratch, sizeof scratch, MSG_DONTWAIT);
    if (n > 0) continue;
    if (n == 0) {
      throw LinkError(LinkErrorKind::PortLost,
                      fmt::format("the connection to {} was closed by the other end", url()));
    }
    if (errno == EINTR) continue;
    if (errno == EAGAIN) return;
    fail("read", errno);
  }
}

}  // namespace lec6::transport
