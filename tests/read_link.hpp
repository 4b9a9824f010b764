#pragma once
// Test helper for any client::Link (pty, TCP, the twin's tap): up to `count`
// bytes before `timeout`, fewer when the link goes quiet that long.

#include <chrono>
#include <cstddef>
#include <span>

#include "lec6/client/link.hpp"
#include "lec6/modbus/pdu.hpp"

namespace lec6::testing {

inline modbus::Bytes read_link(client::Link& link, std::size_t count,
                               Duration timeout = std::chrono::seconds(2)) {
  const TimePoint deadline = link.clock().now() + timeout;
  modbus::Bytes out(count);
  std::size_t got = 0;
  while (got < count) {
    const std::size_t n = link.read_some(std::span(out).subspan(got), deadline);
    if (n == 0) break;
    got += n;
  }
  out.resize(got);
  return out;
}

}  // namespace lec6::testing
