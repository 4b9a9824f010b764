#include "lec6/transport/tcp_server.hpp"

#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <sys/socket.h>

#include <cerrno>
#include <memory>

#include <fmt/format.h>

#include "lec6/client/link.hpp"

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
  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_STREAM;
  hints.ai_protocol = IPPROTO_TCP;
  hints.ai_flags = AI_PASSIVE | AI_NUMERICSERV;
  addrinfo* found = nullptr;
  const std::string service = std::to_string(port);
  const char* node = address_.empty() ? nullptr : address_.c_str();
  if (int err = ::getaddrinfo(node, service.c_str(), &hints, &found); err != 0) {
    unavailable(err == EAI_SYSTEM ? errno_text(errno) : std::string(::gai_strerror(err)));
  }
  std::unique_ptr<addrinfo, void (*)(addrinfo*)> list(found, ::freeaddrinfo);

  std::string last_error = "no address";
  for (const addrinfo* ai = list.get(); ai != nullptr; ai = ai->ai_next) {
    UniqueFd fd(
        ::socket(ai->ai_family, ai->ai_socktype | SOCK_NONBLOCK | SOCK_CLOEXEC, ai->ai_protocol));
    if (!fd) {
      last_error = errno_text(errno);
      continue;
    }
    const int one = 1;
    ::setsockopt(fd.get(), SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
    if (::bind(fd.get(), ai->ai_addr, ai->ai_addrlen) != 0 || ::listen(fd.get(), backlog) != 0) {
      last_error = errno_text(errno);
      continue;
    }
    sockaddr_storage bound{};
    socklen_t len = sizeof bound;
    if (::getsockname(fd.get(), reinterpret_cast<sockaddr*>(&bound), &len) == 0) {
      if (bound.ss_family == AF_INET) {
        port_ = ntohs(reinterpret_cast<const sockaddr_in*>(&bound)->sin_port);
      } else if (bound.ss_family == AF_INET6) {
        port_ = ntohs(reinterpret_cast<const sockaddr_in6*>(&bound)->sin6_port);
      }
    }
    fd_ = std::move(fd);
    return;
  }
  unavailable(last_error);
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
