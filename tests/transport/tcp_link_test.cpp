// TcpLink against TcpListener on the loopback interface: real sockets, every
// wait a poll() with a deadline.

#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "lec6/transport/fd.hpp"
#include "lec6/transport/tcp_link.hpp"
#include "lec6/transport/tcp_server.hpp"
#include "read_link.hpp"

namespace lec6::transport {
namespace {

using namespace std::chrono_literals;
using client::LinkError;
using client::LinkErrorKind;
using ::testing::AllOf;
using ::testing::HasSubstr;

const SteadyClock kTcpClock;
using Bytes = std::vector<uint8_t>;
const Bytes kTcpQuery = {0x01, 0x03, 0x90, 0x00, 0x00, 0x02, 0xE9, 0x0B};
const Bytes kTcpReply = {0x01, 0x03, 0x04, 0x00, 0x00, 0x27, 0x10, 0xE2, 0x1F};

TimePoint tcp_from_now(Duration d) {
  return kTcpClock.now() + d;
}

LinkError tcp_link_error(const std::function<void()>& f) {
  try {
    f();
  } catch (const LinkError& e) {
    return e;
  }
  ADD_FAILURE() << "no LinkError thrown";
  return LinkError(LinkErrorKind::Io, "none");
}

UniqueFd accept_tcp(TcpListener& listener) {
  const TimePoint deadline = tcp_from_now(2s);
  for (;;) {
    if (poll_until(listener.fd(), POLLIN, deadline, kTcpClock) == 0) return UniqueFd();
    if (UniqueFd fd = listener.accept()) return fd;
  }
}

Bytes recv_fd(int fd, std::size_t count) {
  const TimePoint deadline = tcp_from_now(2s);
  Bytes out;
  while (out.size() < count && poll_until(fd, POLLIN, deadline, kTcpClock) != 0) {
    uint8_t buffer[256];
    const ssize_t n = ::recv(fd, buffer, std::min(sizeof buffer, count - out.size()), 0);
    if (n <= 0) break;
    out.insert(out.end(), buffer, buffer + n);
  }
  return out;
}

void send_fd(int fd, std::span<const uint8_t> data) {
  ASSERT_EQ(::send(fd, data.data(), data.size(), MSG_NOSIGNAL), static_cast<ssize_t>(data.size()));
}

using testing::read_link;

struct Connected {
  TcpListener listener;
  TcpLink link;
  UniqueFd server;
  explicit Connected(TcpOptions options = {})
      : link("127.0.0.1", listener.port(), options), server(accept_tcp(listener)) {}
};

TEST(TcpListener, BindsTheLoopbackOnAFreePortAndAcceptsWithoutBlocking) {
  TcpListener listener;
  EXPECT_NE(listener.port(), 0);
  EXPECT_EQ(listener.address(), "127.0.0.1");
  EXPECT_EQ(listener.url(), "tcp://127.0.0.1:" + std::to_string(listener.port()));
  EXPECT_FALSE(listener.accept().valid());  // nothing pending: returns at once
}

TEST(TcpListener, APortInUseIsPortUnavailable) {
  TcpListener first;
  const LinkError e = tcp_link_error([&] { TcpListener second(first.port()); });
  EXPECT_EQ(e.kind(), LinkErrorKind::PortUnavailable);
  EXPECT_THAT(e.what(),
              HasSubstr("cannot listen on tcp://127.0.0.1:" + std::to_string(first.port())));
}

TEST(TcpLink, RoundTrip) {
  Connected c(TcpOptions{.baud = 115200});
  ASSERT_TRUE(c.server.valid());
  EXPECT_EQ(c.link.baud(), 115200u);
  EXPECT_EQ(c.link.describe(),
            "tcp://127.0.0.1:" + std::to_string(c.listener.port()) + " @ 115200");

  c.link.write(kTcpQuery);
  EXPECT_EQ(recv_fd(c.server.get(), kTcpQuery.size()), kTcpQuery);
  send_fd(c.server.get(), kTcpReply);
  EXPECT_EQ(read_link(c.link, kTcpReply.size()), kTcpReply);
}

TEST(TcpLink, ReadSomeReturnsZeroOnlyOnceTheDeadlineHasPassed) {
  Connected c;
  uint8_t buffer[16];
  const TimePoint deadline = tcp_from_now(30ms);
  EXPECT_EQ(c.link.read_some(buffer, deadline), 0u);
  EXPECT_GE(c.link.clock().now(), deadline);
}

TEST(TcpLink, DiscardInputDropsStaleBytes) {
  Connected c;
  send_fd(c.server.get(), Bytes{0xAA, 0xBB});
  ASSERT_NE(poll_until(c.link.fd(), POLLIN, tcp_from_now(2s), kTcpClock), 0);
  c.link.discard_input();
  uint8_t buffer[16];
  EXPECT_EQ(c.link.read_some(buffer, tcp_from_now(20ms)), 0u);
  send_fd(c.server.get(), kTcpReply);
  EXPECT_EQ(read_link(c.link, kTcpReply.size()), kTcpReply);
}

TEST(TcpLink, PeerClosingIsPortLostPromptly) {
  Connected c;
  c.server.reset();
  uint8_t buffer[16];
  const TimePoint deadline = tcp_from_now(10s);
  const LinkError e = tcp_link_error([&] { c.link.read_some(buffer, deadline); });
  EXPECT_EQ(e.kind(), LinkErrorKind::PortLost);
  EXPECT_THAT(e.what(), HasSubstr("tcp://127.0.0.1:"));
  EXPECT_LT(kTcpClock.now(), deadline - 9s);
}

TEST(TcpLink, WritingToAClosedPeerIsPortLost) {
  Connected c;
  c.server.reset();
  // The first send is still accepted locally; the peer answers it with a
  // reset, which poll reports as an error condition (events 0: errors only).
  c.link.write(kTcpQuery);
  ASSERT_NE(poll_until(c.link.fd(), 0, tcp_from_now(2s), kTcpClock), 0);
  const LinkError e = tcp_link_error([&] { c.link.write(kTcpQuery); });
  EXPECT_EQ(e.kind(), LinkErrorKind::PortLost);
  EXPECT_THAT(e.what(), AllOf(HasSubstr("the connection to tcp://127.0.0.1:"),
                              HasSubstr("went away (write: ")));
}

TEST(TcpLink, ConnectionRefusedIsPortUnavailable) {
  uint16_t port = 0;
  {
    TcpListener listener;
    port = listener.port();
  }
  const LinkError e = tcp_link_error([&] { TcpLink link("127.0.0.1", port); });
  EXPECT_EQ(e.kind(), LinkErrorKind::PortUnavailable);
  EXPECT_EQ(std::string(e.what()),
            "cannot connect to tcp://127.0.0.1:" + std::to_string(port) + ": Connection refused");
}

TEST(TcpLink, ConnectIsBoundedByTheTimeout) {
  // A listener whose accept queue is full drops further SYNs, so the next
  // connect gets no answer at all: the timeout must end it.
  TcpListener listener(0, "127.0.0.1", 0);
  std::vector<std::unique_ptr<TcpLink>> queued;
  const TcpOptions options{.connect_timeout = std::chrono::milliseconds(200)};
  std::optional<LinkError> error;
  Duration took{};
  for (int i = 0; i < 8 && !error; ++i) {
    const TimePoint start = kTcpClock.now();
    try {
      queued.push_back(std::make_unique<TcpLink>("127.0.0.1", listener.port(), options));
    } catch (const LinkError& e) {
      error = e;
      took = kTcpClock.now() - start;
    }
  }
  ASSERT_TRUE(error.has_value()) << "the accept queue never filled up";
  EXPECT_EQ(error->kind(), LinkErrorKind::PortUnavailable);
  EXPECT_EQ(std::string(error->what()),
            "cannot connect to tcp://127.0.0.1:" + std::to_string(listener.port()) +
                ": no answer within 200 ms");
  EXPECT_GE(took, std::chrono::milliseconds(200));
  EXPECT_LT(took, 2s);
}

}  // namespace
}  // namespace lec6::transport
