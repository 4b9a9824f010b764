#pragma once
// Modbus TCP (MBAP) master: `lec --port tcp://host:502`, Python's
// `lec6.connect("tcp://...")`, and any program that reaches controllers
// through `lec serve` or another Modbus TCP gateway. The unit id is the
// controller ID; the transaction id matches each reply to its request, so a
// late reply to an earlier request is recognised and dropped.
//
// Gateway exceptions become transport errors in the user's terms: 0A (no such
// unit on the gateway) → TransportError Unreachable; 0B (the unit did not
// answer) → TransportError Timeout, which the Client retries like a lost reply.
//
// A connection that drops is reopened by the next exchange.
//
// Thread safety: one thread at a time.

#include <cstdint>
#include <memory>
#include <string>

#include "lec6/client/master.hpp"
#include "lec6/modbus/mbap.hpp"
#include "lec6/transport/tcp_link.hpp"

namespace lec6::transport {

struct ModbusTcpOptions {
  // The serial line behind the gateway, for limits only (never sent).
  modbus::LineTiming line;
  // How long to wait for a reply. A gateway queues requests behind others on
  // its line, so this is longer than a serial Tx.
  Duration timeout = std::chrono::milliseconds(1000);
  Duration connect_timeout = std::chrono::seconds(3);
  client::TraceSink trace{};
};

class ModbusTcpMaster final : public client::Master {
 public:
  // Connects at once (TransportError Port naming tcp://host:port on failure).
  ModbusTcpMaster(std::string host, uint16_t port, ModbusTcpOptions options = {});
  ~ModbusTcpMaster() override;

  modbus::ResponseFrame exchange(const modbus::RequestFrame& frame) override;
  const Clock& clock() const override { return clock_; }
  // "tcp://host:502 (Modbus TCP)"
  std::string describe() const override;
  client::LinkStats stats() const override { return stats_; }
  Duration last_round_trip() const override { return last_round_trip_; }
  const modbus::LineTiming& line_timing() const override { return options_.line; }

  std::string url() const;

 private:
  void connect();
  modbus::ResponseFrame await_reply(const modbus::RequestFrame& frame, uint16_t transaction,
                                    TimePoint start);
  modbus::ResponseFrame checked(const modbus::RequestFrame& frame, const modbus::MbapAdu& adu,
                                TimePoint start);
  void trace(bool outgoing, TimePoint at, std::span<const uint8_t> bytes,
             const modbus::RequestFrame& request, const modbus::ResponseFrame* response);

  std::string host_;
  uint16_t port_;
  ModbusTcpOptions options_;
  SteadyClock clock_;
  std::unique_ptr<TcpLink> link_;
  modbus::MbapFramer framer_;
  uint16_t next_transaction_ = 1;
  client::LinkStats stats_;
  Duration last_round_trip_{};
};

}  // namespace lec6::transport
