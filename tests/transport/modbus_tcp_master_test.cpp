// ModbusTcpMaster against a scripted server on the loopback interface: the
// server's replies are queued in the socket before each exchange, so the
// tests need no threads and no sleeps.

#include "lec6/transport/modbus_tcp_master.hpp"

#include <poll.h>
#include <sys/socket.h>

#include <future>
#include <thread>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "lec6/client/client.hpp"
#include "lec6/client/errors.hpp"
#include "lec6/transport/fd.hpp"
#include "lec6/transport/tcp_server.hpp"

namespace lec6::transport {
namespace {

using namespace std::chrono_literals;
using client::TransportError;
using client::TransportErrorKind;
using modbus::Bytes;
using ::testing::HasSubstr;

const SteadyClock kClock;

UniqueFd accept_one(TcpListener& listener) {
  const TimePoint deadline = kClock.now() + 2s;
  for (;;) {
    if (poll_until(listener.fd(), POLLIN, deadline, kClock) == 0) return UniqueFd();
    if (UniqueFd fd = listener.accept()) return fd;
  }
}

Bytes recv_some(int fd) {
  Bytes out(512);
  if (poll_until(fd, POLLIN, kClock.now() + 2s, kClock) == 0) return {};
  const ssize_t n = ::recv(fd, out.data(), out.size(), 0);
  out.resize(n > 0 ? static_cast<std::size_t>(n) : 0);
  return out;
}

void send_all(int fd, const Bytes& data) {
  ASSERT_EQ(::send(fd, data.data(), data.size(), MSG_NOSIGNAL), static_cast<ssize_t>(data.size()));
}

Bytes reply(uint16_t transaction, uint8_t unit, const modbus::Response& r) {
  return modbus::encode_mbap(transaction, unit, modbus::encode_response_pdu(r));
}

struct Gateway {
  TcpListener listener;
  std::unique_ptr<ModbusTcpMaster> master;
  UniqueFd server;
  explicit Gateway(Duration timeout = 500ms) {
    ModbusTcpOptions o;
    o.timeout = timeout;
    master = std::make_unique<ModbusTcpMaster>("127.0.0.1", listener.port(), o);
    server = accept_one(listener);
  }
};

const modbus::RequestFrame kReadState{1, modbus::ReadRegistersRequest{0x9000, 7}};
const modbus::ReadRegistersResponse kState{{0, 15000, 0, 0, 0, 15000, 0}};

TEST(ModbusTcpMaster, SendsMbapAndReturnsTheMatchingReply) {
  Gateway g;
  send_all(g.server.get(), reply(1, 1, kState));
  const auto r = g.master->exchange(kReadState);
  EXPECT_EQ(std::get<modbus::ReadRegistersResponse>(r.pdu), kState);
  EXPECT_EQ(modbus::to_hex(recv_some(g.server.get())), "00 01 00 00 00 06 01 03 90 00 00 07");
  EXPECT_EQ(g.master->describe(),
            "tcp://127.0.0.1:" + std::to_string(g.listener.port()) + " (Modbus TCP)");
}

TEST(ModbusTcpMaster, DropsALateReplyToAnEarlierTransaction) {
  Gateway g(100ms);
  EXPECT_THROW(g.master->exchange(kReadState), TransportError);  // transaction 1: no reply
  // Now the late reply to 1 arrives, then the reply to 2.
  Bytes both = reply(1, 1, modbus::ReadRegistersResponse{{9, 9, 9, 9, 9, 9, 9}});
  const Bytes second = reply(2, 1, kState);
  both.insert(both.end(), second.begin(), second.end());
  send_all(g.server.get(), both);
  EXPECT_EQ(std::get<modbus::ReadRegistersResponse>(g.master->exchange(kReadState).pdu), kState);
  EXPECT_EQ(g.master->stats().bytes_discarded, 7u + 2u + 14u);  // header, FC + count, 7 words
}

TEST(ModbusTcpMaster, GatewayExceptionsBecomeTransportErrorsInTheUsersTerms) {
  Gateway g;
  using modbus::ExceptionCode;
  send_all(g.server.get(),
           reply(1, 1,
                 modbus::ExceptionResponse{modbus::FunctionCode::ReadRegisters, 0x03,
                                           ExceptionCode::GatewayTargetFailed}));
  try {
    g.master->exchange(kReadState);
    FAIL();
  } catch (const TransportError& e) {
    EXPECT_EQ(e.kind(), TransportErrorKind::Timeout);
    EXPECT_THAT(e.what(), HasSubstr("controller ID 1 did not answer"));
  }
  send_all(g.server.get(),
           reply(2, 1,
                 modbus::ExceptionResponse{modbus::FunctionCode::ReadRegisters, 0x03,
                                           ExceptionCode::GatewayPathUnavailable}));
  try {
    g.master->exchange(kReadState);
    FAIL();
  } catch (const TransportError& e) {
    EXPECT_EQ(e.kind(), TransportErrorKind::Unreachable);
    EXPECT_THAT(e.what(), HasSubstr("no controller with ID 1"));
  }
  // A controller's own exception is the Client's business: returned as it is.
  send_all(g.server.get(), reply(3, 1,
                                 modbus::ExceptionResponse{modbus::FunctionCode::ReadRegisters,
                                                           0x03, ExceptionCode::IllegalAddress}));
  EXPECT_TRUE(
      std::holds_alternative<modbus::ExceptionResponse>(g.master->exchange(kReadState).pdu));
}

TEST(ModbusTcpMaster, AnRtuServerIsNamedWithTheRightUrl) {
  Gateway g;
  send_all(g.server.get(), Bytes{0x01, 0x03, 0x04, 0x00, 0x00, 0x27, 0x10, 0xE2, 0x1F});
  try {
    g.master->exchange(kReadState);
    FAIL();
  } catch (const TransportError& e) {
    EXPECT_EQ(e.kind(), TransportErrorKind::Framing);
    EXPECT_THAT(e.what(), HasSubstr("use rtu+tcp://127.0.0.1:"));
  }
}

TEST(ModbusTcpMaster, ATimeoutSuggestsRtuOverTcp) {
  Gateway g(50ms);
  try {
    g.master->exchange(kReadState);
    FAIL();
  } catch (const TransportError& e) {
    EXPECT_EQ(e.kind(), TransportErrorKind::Timeout);
    EXPECT_THAT(e.what(), HasSubstr("within 50 ms"));
    EXPECT_THAT(e.what(), HasSubstr("rtu+tcp://"));
  }
}

TEST(ModbusTcpMaster, ReconnectsAfterTheGatewayClosedTheConnection) {
  Gateway g;
  g.server.reset();  // the gateway restarts
  try {
    g.master->exchange(kReadState);
    FAIL();
  } catch (const TransportError& e) {
    EXPECT_EQ(e.kind(), TransportErrorKind::Port);
  }
  // The next exchange connects again; the new connection's first transaction answers.
  auto pending = std::async(std::launch::async, [&] {
    UniqueFd fd = accept_one(g.listener);
    const Bytes q = recv_some(fd.get());
    if (q.size() >= 2)
      send_all(fd.get(), reply(static_cast<uint16_t>((q[0] << 8) | q[1]), 1, kState));
    return fd;
  });
  EXPECT_EQ(std::get<modbus::ReadRegistersResponse>(g.master->exchange(kReadState).pdu), kState);
  pending.get();
}

TEST(ModbusTcpMaster, CarriesTheTypedClient) {
  Gateway g;
  send_all(g.server.get(), reply(1, 1, kState));
  client::Client c(*g.master, {.id = 1});
  EXPECT_EQ(c.read_state().target_001mm, 15000);
}

}  // namespace
}  // namespace lec6::transport
