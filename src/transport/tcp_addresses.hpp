#pragma once
// The one getaddrinfo loop of the TCP transports (TcpLink connects,
// TcpListener listens): each address of a name in turn, with a fresh
// non-blocking socket, until one can be used.

#include <netdb.h>

#include <cstdint>
#include <functional>
#include <string>

#include "lec6/transport/fd.hpp"

namespace lec6::transport {

struct FirstAddress {
  UniqueFd fd;        // invalid when no address could be used
  std::string error;  // then why: the resolver's error, or the last address's
};

// Resolves `node` (null with `passive`: every local address) and `port` for
// TCP, and calls `use(address, fd)` with a new non-blocking, close-on-exec
// socket for each address in turn: it returns "" when the socket is ready
// (connected, listening), else why not, and the next address is tried.
FirstAddress first_usable_address(const char* node, uint16_t port, bool passive,
                                  const std::function<std::string(const addrinfo&, int)>& use);

}  // namespace lec6::transport
