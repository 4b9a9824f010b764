#pragma once
// Which requests stop the axis: the one rule, used by Ctrl-C on the client's
// own line (a stop after Ctrl-C is made of requests, and they must reach the
// controller even while the interrupt is still pending: RtuMaster's
// `interrupted` hook) and by lec serve (they go at Priority::Emergency, ahead
// of every other client and to a controller that stopped answering).
//
// Thread safety: a pure function of its argument, safe from any thread.

#include "lec6/modbus/pdu.hpp"

namespace lec6::client {

// A coil write (FC05, or FC0F over several coils) that stops or releases the
// axis and starts nothing:
//   - it stops when it writes RESET ← 1, HOLD ← 1 or SVON ← 0;
//   - otherwise, when each coil it writes that matters releases (RESET,
//     DRIVE, SETUP, JOG−, JOG+ ← 0) and none starts (SVON, DRIVE, SETUP,
//     JOG−, JOG+ ← 1, or HOLD ← 0, which resumes a held operation).
// IN0–IN5 and Y30 neither stop nor start. Reads, register writes (a D9100
// start) and coil values other than FF00/0000 (refused: exception 03) are
// not stops. The table test is tests/client/stop_rule_test.cpp.
bool stops_or_releases(const modbus::Request& request) noexcept;

}  // namespace lec6::client
