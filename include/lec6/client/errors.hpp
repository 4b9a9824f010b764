#pragma once
// What can go wrong talking to a controller, kept apart by who is at fault:
// the line (TransportError), the controller refusing a request
// (ControllerException), the controller stopping with an alarm (AlarmError),
// an operation running past its deadline (DeadlineError), a start the
// controller never acted on (MoveNotStarted), or the caller interrupting
// (Cancelled). All derive from lec6::Error (lec6/error.hpp). The ones a move
// can end with carry its MoveResult (outcome and timeline), so a caller can
// print the move's one line.
//
// Thread safety: exception objects are immutable; copies may be used from any thread.

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "lec6/client/move_result.hpp"
#include "lec6/error.hpp"
#include "lec6/modbus/pdu.hpp"

namespace lec6::client {

enum class TransportErrorKind {
  Port,          // cannot open, or the port went away
  Timeout,       // no reply within Tx + margin
  Crc,           // reply bytes arrived but failed the CRC (noise, or wrong baud)
  Framing,       // bytes arrived that never formed the expected reply
  EchoMismatch,  // 2-wire echo differs: bus collision
  LineBusy,      // the line never went quiet for Ts before sending: noise, another master
  Unreachable,   // a gateway has no path to the unit (Modbus TCP exception 0A)
};

std::string_view transport_error_name(TransportErrorKind k) noexcept;

// A fault of one exchange on a working line (timeout, CRC, framing, echo,
// line busy): the next exchange may pass. Not a port that is gone, nor a
// gateway without a path to the unit.
bool is_line_fault(TransportErrorKind k) noexcept;

class TransportError : public Error {
 public:
  TransportError(TransportErrorKind kind, const std::string& what) : Error(what), kind_(kind) {}
  TransportErrorKind kind() const noexcept { return kind_; }

 private:
  TransportErrorKind kind_;
};

// The controller answered with an exception reply (01/02/03).
class ControllerException : public Error {
 public:
  ControllerException(modbus::ExceptionCode code, const std::string& what)
      : Error(what), code_(code) {}
  modbus::ExceptionCode code() const noexcept { return code_; }

 private:
  modbus::ExceptionCode code_;
};

// What a move showed before it ended in one of the errors below; empty when
// the error did not end a move (an alarm already active, an interrupted read).
class WithMoveResult {
 public:
  const std::optional<MoveResult>& move_result() const noexcept { return result_; }

 protected:
  explicit WithMoveResult(std::optional<MoveResult> r) : result_(std::move(r)) {}

 private:
  std::optional<MoveResult> result_;
};

// The controller raised an alarm (X4F = 1) during an operation.
class AlarmError : public Error, public WithMoveResult {
 public:
  AlarmError(std::vector<uint8_t> codes, const std::string& what,
             std::optional<MoveResult> result = std::nullopt)
      : Error(what), WithMoveResult(std::move(result)), codes_(std::move(codes)) {}
  const std::vector<uint8_t>& codes() const noexcept { return codes_; }

 private:
  std::vector<uint8_t> codes_;
};

// An operation did not finish by its deadline (the controller kept answering).
class DeadlineError : public Error, public WithMoveResult {
 public:
  explicit DeadlineError(const std::string& what, std::optional<MoveResult> result = std::nullopt)
      : Error(what), WithMoveResult(std::move(result)) {}
};

// The caller asked to stop (Ctrl-C): a waiting move was stopped before this
// was thrown; a wait on the line (Master) ended without a reply.
class Cancelled : public Error, public WithMoveResult {
 public:
  explicit Cancelled(const std::string& what, std::optional<MoveResult> result = std::nullopt)
      : Error(what), WithMoveResult(std::move(result)) {}
};

// lec serve did not carry out a write that would start or resume motion: a
// stop to its controller, accepted after it, came first (docs/serve.md, "A
// stop supersedes the starts queued before it"). Not retried.
class Superseded : public Cancelled {
 public:
  using Cancelled::Cancelled;
};

// Nothing showed that the controller started a move within the start window
// (client/completion.hpp): never taken for success. A stop (RESET pulse) was
// sent before this was thrown, so a start processed late cannot run unattended.
class MoveNotStarted : public Error, public WithMoveResult {
 public:
  MoveNotStarted(const std::string& what, MoveResult result)
      : Error(what), WithMoveResult(std::move(result)) {}
};

// A request refused before anything was sent (value out of range, address
// outside the map): nothing reached the controller.
class InvalidRequest : public InvalidArgument {
 public:
  using InvalidArgument::InvalidArgument;
};

}  // namespace lec6::client
