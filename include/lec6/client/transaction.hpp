#pragma once
// One request/reply exchange as a sans-I/O state machine: it is told what
// happened (sent, bytes arrived at t, time passed) and says what to do next
// (send these bytes, wait for input until t, done, failed). The Client drives
// it over a Link; tests drive it by hand on a virtual clock.
//
// Thread safety: a Transaction is used by one thread at a time.

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <utility>

#include "lec6/client/errors.hpp"
#include "lec6/clock.hpp"
#include "lec6/modbus/framer.hpp"
#include "lec6/modbus/pdu.hpp"
#include "lec6/modbus/timing.hpp"

namespace lec6::client {

struct TransactionTiming {
  modbus::LineTiming line;
  Duration margin = std::chrono::milliseconds(50);  // added to Tx for the reply timeout
};

class Transaction {
 public:
  enum class Step {
    Send,     // send bytes(), then call sent()
    Receive,  // read until deadline(); call received() or timed_out()
    Done,     // response() is the verified reply (none for broadcast)
    Failed,   // error() says why
  };

  Transaction(const modbus::RequestFrame& request, const TransactionTiming& timing);

  Step step() const noexcept { return step_; }
  const modbus::Bytes& bytes() const noexcept { return query_; }
  TimePoint deadline() const noexcept { return deadline_; }
  bool broadcast() const noexcept { return request_.id == modbus::kBroadcastId; }

  // The query's last byte left at `t`. A broadcast gets no reply: wait Tx,
  // then it is done (manual §8.4 asks for Tx before the next query).
  void sent(TimePoint t);
  void received(std::span<const uint8_t> bytes, TimePoint t);
  void timed_out(TimePoint t);

  const modbus::ResponseFrame& response() const { return *response_; }
  // Moves the verified reply out (Done only; response() is empty after).
  modbus::ResponseFrame take_response() { return std::move(*response_); }
  const std::optional<modbus::ResponseFrame>& maybe_response() const { return response_; }
  TransportErrorKind error_kind() const noexcept { return error_kind_; }
  const std::string& error() const noexcept { return error_; }
  TimePoint sent_at() const noexcept { return sent_at_; }
  TimePoint finished_at() const noexcept { return finished_at_; }
  const modbus::RequestFrame& request() const noexcept { return request_; }
  std::size_t discarded() const noexcept { return framer_.discarded(); }

 private:
  void fail(TransportErrorKind kind, std::string why, TimePoint t);

  modbus::RequestFrame request_;
  TransactionTiming timing_;
  modbus::Bytes query_;
  modbus::ClientFramer framer_;
  Step step_ = Step::Send;
  TimePoint deadline_{};
  TimePoint sent_at_{};
  TimePoint finished_at_{};
  std::optional<modbus::ResponseFrame> response_;
  TransportErrorKind error_kind_ = TransportErrorKind::Timeout;
  std::string error_;
};

}  // namespace lec6::client
