#include "lec6/transport/tcp_server.hpp"

#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <sys/socket.h>

#include <cerrno>
#include <memory>

#include <fmt/format.h>

#include "lec6/client/link.hpp"
#include "tcp_addresses.hpp"

namespace lec6::transport {

namespace {
using client::LinkError;
using client::LinkErrorKind;
}  // namespace

TcpListener::TcpListener(uint16_t port, std::string address, int backlog)
    : address_(std::move(address)), port_(port) {
  auto unavailable = [this](const std::string& why) {
    throw LinkError(LinkErrorKind::PortUnavailable,
                    fmt::format("cannot listen on {}: {}", url(), why));
  };
  const char* node = address_.empty() ? nullptr : address_.c_str();
  FirstAddress first = first_usable_address(node, port, true, [&](const addrinfo& ai, int fd) {
    const int one = 1;
    ::setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
    if (::bind(fd, ai.ai_addr, ai.ai_addrlen) != 0 || ::listen(fd, backlog) != 0) {
      return errno_text(errno);
    }
    return std::string();
  });
  if (!first.fd) unavailable(first.error);
  sockaddr_storage bound{};
  socklen_t len = sizeof bound;
  if (::getsockname(first.fd.get(), reinterpret_cast<sockaddr*>(&bound), &len) == 0) {
    if (bound.ss_family == AF_INET) {
      port_ = ntohs(reinterpret_cast<const sockaddr_in*>(&bound)->sin_port);
    } else if (bound.ss_family == AF_INET6) {
      port_ = ntohs(reinterpret_cast<const sockaddr_in6*>(&bound)->sin6_port);
    }
  }
  fd_ = std::move(first.fd);
}

std::string TcpListener::url() const {
  if (address_.find(':') != std::string::npos) return fmt::format("tcp://[{}]:{}", address_, port_);
  return fmt::format("tcp://{}:{}", address_, port_);
}

UniqueFd TcpListener::accept() {
  for (;;) {
    const int fd = ::accept4(fd_.get(), nullptr, nullptr, SOCK_NONBLOCK | SOCK_CLOEXEC);
    if (fd >= 0) {
      const int one = 1;
      ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
      return UniqueFd(fd);
    }
    const int err = errno;
    if (err == EINTR) continue;
    // Nothing pending, or a client that gave up before we got to it.
    if (err == EAGAIN || err == ECONNABORTED || err == EPROTO) return UniqueFd();
    throw LinkError(LinkErrorKind::Io,
                    fmt::format("accept on {} failed: {}", url(), errno_text(err)));
  }
}

}  // namespace lec6::transport
