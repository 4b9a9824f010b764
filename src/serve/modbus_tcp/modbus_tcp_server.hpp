#pragma once
// The Modbus TCP listener of one line (MBAP, per the Modbus Messaging on
// TCP/IP Implementation Guide): unit id → controller ID, the transaction id
// echoed, many connections, requests pipelined per connection (answered as
// they complete; the transaction id matches them). What each request becomes
// is gateway.hpp's rule.
//
// A connection that breaks the MBAP framing (protocol id ≠ 0, a lying
// length) is closed, and only that one. A connection that closes with
// requests queued cancels them, except stops: an accepted stop is never
// cancelled (a PLC that writes HOLD and hangs up still holds its axis); one
// on the wire completes and its reply is dropped.
//
// Bounded (ModbusTcpLimits): a connection holds at most `max_queued`
// requests queued on the line plus replies unwritten, and as many frames read
// waiting for room; a frame beyond those that is not a stop is answered at
// once with exception 06 (server busy). Stops are always taken and go to the
// line at once, with the frames read before them in order, however full the
// connection is (issue 31 rule 4:
// ModbusTcpServer.AStopBehindAFloodOfPipelinedRequestsGoesAtOnce). Only
// replies the master does not read stop its socket being read; at most
// `max_connections` connections (more are closed at once, with a log line);
// a connection with no request for `idle_timeout` and nothing owed is closed;
// running out of file descriptors at accept retries after 100 ms, never in a
// spin. Stops (client::stops_or_releases) go at Priority::Emergency.
//
// Thread safety: constructed, stopped and destroyed on the io_context's
// thread (or before it runs); line completions are posted to it.

#include <asio.hpp>

#include <chrono>
#include <cstdint>
#include <memory>
#include <set>
#include <string>

#include "lec6/serve/config.hpp"
#include "lec6/serve/log.hpp"
#include "line/line.hpp"
#include "modbus_tcp/gateway.hpp"

namespace lec6::serve {

struct ModbusTcpLimits {
  std::size_t max_queued = 32;  // per connection: requests queued + replies unwritten
  std::size_t max_connections = 64;
  std::chrono::milliseconds idle_timeout{60000};  // 0: never
};

class ModbusTcpServer {
 public:
  enum class Framing { Mbap, Rtu };  // Modbus TCP, or RTU frames over TCP

  ModbusTcpServer(asio::io_context& io, const ListenerConfig& config, Framing framing, Line& line,
                  GatewayPolicy policy, Log log, ModbusTcpLimits limits = {});
  ~ModbusTcpServer();
  ModbusTcpServer(const ModbusTcpServer&) = delete;
  ModbusTcpServer& operator=(const ModbusTcpServer&) = delete;

  uint16_t port() const noexcept { return port_; }
  std::size_t connections() const noexcept { return sessions_.size(); }
  std::size_t refused() const noexcept { return refused_; }
  // "tcp://127.0.0.1:1502" or "rtu+tcp://127.0.0.1:1503"
  std::string url() const;
  // Stops accepting; each connection closes once the answers it is owed
  // are written (the line fails its queued jobs when it stops).
  void shutdown();
  // Stops accepting and closes every connection now.
  void stop();

  class Session;

 private:
  void accept();
  void refuse(asio::ip::tcp::socket socket);

  asio::io_context& io_;
  asio::ip::tcp::acceptor acceptor_;
  asio::steady_timer retry_;
  ModbusTcpLimits limits_;
  std::size_t refused_ = 0;
  std::chrono::steady_clock::time_point last_refusal_log_{};
  Framing framing_;
  Line& line_;
  GatewayPolicy policy_;
  Log log_;
  std::string address_;
  uint16_t port_ = 0;
  std::set<std::shared_ptr<Session>> sessions_;
  bool stopped_ = false;
};

}  // namespace lec6::serve
