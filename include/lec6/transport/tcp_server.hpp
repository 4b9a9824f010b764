#pragma once
// A listening TCP socket for the twin's server loop: the loop polls fd() for
// POLLIN and calls accept(). Deliberately minimal: no threads, no loop.
//
// Thread safety: one thread at a time (the loop that polls it).

#include <cstdint>
#include <string>

#include "lec6/transport/fd.hpp"

namespace lec6::transport {

class TcpListener {
 public:
  // Binds (SO_REUSEADDR) and listens. `port` 0 picks a free port; port()
  // tells which. `address` is a numeric address or a host name
  // ("127.0.0.1", "0.0.0.0", "::", "localhost"). Throws client::LinkError
  // PortUnavailable ("cannot listen on tcp://127.0.0.1:502: ...").
  explicit TcpListener(uint16_t port = 0, std::string address = "127.0.0.1", int backlog = 8);

  // Non-blocking listening socket.
  int fd() const { return fd_.get(); }
  uint16_t port() const { return port_; }
  const std::string& address() const { return address_; }
  // "tcp://127.0.0.1:5020" ("tcp://[::1]:5020" for IPv6).
  std::string url() const;

  // Takes one pending connection without blocking: an invalid UniqueFd when
  // none is pending. The accepted socket is non-blocking, close-on-exec, with
  // TCP_NODELAY. Throws client::LinkError (Io) on other errors.
  UniqueFd accept();

 private:
  UniqueFd fd_;
  std::string address_;
  uint16_t port_ = 0;
};

}  // namespace lec6::transport
