#pragma once
// Frames explained in the manual's terms, one line each:
//   01 05 00 19 FF 00 5D FD  →  "ID 1 write Y19 SVON = ON"
// Used by `lec decode`, `--trace` and the twin's trace.
//
// Thread safety: pure functions.

#include <cstdint>
#include <span>
#include <string>

#include "lec6/modbus/pdu.hpp"

namespace lec6::lec {

std::string explain_request(const modbus::RequestFrame& frame);

// `request` (when known) gives the addresses the reply's values belong to.
std::string explain_response(const modbus::ResponseFrame& frame,
                             const modbus::RequestFrame* request = nullptr);

// Which side of a transaction a frame is.
enum class FrameRole : uint8_t { Request, Reply };

// Decodes raw bytes as a request or a reply, as `role` says, and explains
// it; the error text when it does not decode.
std::string explain_bytes(std::span<const uint8_t> adu, FrameRole role);

}  // namespace lec6::lec
