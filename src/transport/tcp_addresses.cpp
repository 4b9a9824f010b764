#include "tcp_addresses.hpp"

#include <netinet/in.h>
#include <sys/socket.h>

#include <cerrno>
#include <memory>

namespace lec6::transport {

FirstAddress first_usable_address(const char* node, uint16_t port, bool passive,
                                  const std::function<std::string(const addrinfo&, int)>& use) {
  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_STREAM;
  hints.ai_protocol = IPPROTO_TCP;
  hints.ai_flags = AI_NUMERICSERV | (passive ? AI_PASSIVE : 0);
  addrinfo* found = nullptr;
  const std::string service = std::to_string(port);
  if (int err = ::getaddrinfo(node, service.c_str(), &hints, &found); err != 0) {
    return {UniqueFd(), err == EAI_SYSTEM ? errno_text(errno) : std::string(::gai_strerror(err))};
  }
  std::unique_ptr<addrinfo, void (*)(addrinfo*)> list(found, ::freeaddrinfo);
  FirstAddress out{UniqueFd(), "no address"};
  for (const addrinfo* ai = list.get(); ai != nullptr; ai = ai->ai_next) {
    UniqueFd fd(
        ::socket(ai->ai_family, ai->ai_socktype | SOCK_NONBLOCK | SOCK_CLOEXEC, ai->ai_protocol));
    if (!fd) {
      out.error = errno_text(errno);
      continue;
    }
    out.error = use(*ai, fd.get());
    if (out.error.empty()) {
      out.fd = std::move(fd);
      return out;
    }
  }
  return out;
}

}  // namespace lec6::transport
