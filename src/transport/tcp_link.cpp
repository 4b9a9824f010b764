#include "lec6/transport/tcp_link.hpp"
#include "lec6/error.hpp"
#include "tcp_addresses.hpp"

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

  const TimePoint deadline = clock_.now() + options_.connect_timeout;
  FirstAddress first =
      first_usable_address(host_.c_str(), port_, false, [&](const addrinfo& ai, int fd) {
        int err = 0;
        if (::connect(fd, ai.ai_addr, ai.ai_addrlen) != 0) {
          err = errno;
          if (err == EINPROGRESS || err == EINTR) {
            short revents = 0;
            try {
              revents = poll_until(fd, POLLOUT, deadline, clock_);
            } catch (const SystemError& e) {
              unavailable(e.what());
            }
            if (revents == 0) {
              return fmt::format("no answer within {:.0f} ms", to_ms(options_.connect_timeout));
            }
            socklen_t len = sizeof err;
            if (::getsockopt(fd, SOL_SOCKET, SO_ERROR, &err, &len) != 0) err = errno;
          }
        }
        return err != 0 ? errno_text(err) : std::string();
      });
  if (!first.fd) unavailable(first.error);
  const int one = 1;
  ::setsockopt(first.fd.get(), IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
  fd_ = std::move(first.fd);
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
  const int fd = fd_.get();
  ReadSome got;
  try {
    got = read_until(fd, buffer, deadline, clock_,
                     [fd](uint8_t* p, std::size_t n) { return ::recv(fd, p, n, 0); });
  } catch (const SystemError& e) {
    fail(e.call().c_str(), e.code().value());
  }
  if (got.closed) {
    throw LinkError(LinkErrorKind::PortLost,
                    fmt::format("the connection to {} was closed by the other end", url()));
  }
  return got.bytes;
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
