#pragma once
// What can go wrong talking to a controller, kept apart by who is at fault:
// the line (TransportError), the controller refusing a request
// (ControllerException), the controller stopping with an alarm (AlarmError),
// or an operation running past its deadline (DeadlineError). All derive from
// lec6::Error (lec6/error.hpp).
//
// Thread safety: exception objects are immutable; copies may be used from any thread.

#include <cstdint>
#include <string>
#include <vector>

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

// The controller raised an alarm (X4F = 1) during an operation.
class AlarmError : public Error {
 public:
  AlarmError(std::vector<uint8_t> codes, const std::string& what)
      : Error(what), codes_(std::move(codes)) {}
  const std::vector<uint8_t>& codes() const noexcept { return codes_; }

 private:
  std::vector<uint8_t> codes_;
};

// An operation did not finish by its deadline (the controller kept answering).
class DeadlineError : public Error {
 public:
  using Error::Error;
};

// The caller asked to stop (Ctrl-C); the axis was stopped before this was thrown.
class Cancelled : public Error {
 public:
  using Error::Error;
};

// A request refused before anything was sent (value out of range, address
// outside the map): nothing reached the controller.
class InvalidRequest : public InvalidArgument {
 public:
  using InvalidArgument::InvalidArgument;
};

}  // namespace lec6::client
