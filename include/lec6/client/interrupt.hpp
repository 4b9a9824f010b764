#pragma once
// Ctrl-C and the line: which requests an interrupt must not stop. A stop
// after Ctrl-C is made of requests, and they must reach the controller even
// while the interrupt is still pending (RtuMaster's `interrupted` hook).
//
// Thread safety: a pure function of its argument, safe from any thread.

#include "lec6/modbus/pdu.hpp"

namespace lec6::client {

// Requests that stop or release the axis: an FC05 write of RESET (either
// level: the pulse), HOLD ← 1, or SVON, DRIVE, SETUP, JOG−, JOG+ ← 0.
bool stops_or_releases(const modbus::Request& request) noexcept;

}  // namespace lec6::client
