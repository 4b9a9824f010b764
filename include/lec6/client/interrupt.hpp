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

// A coil write (FC05, or FC0F over several coils, or FC10 to the control words) that stops or
// releases the axis and starts nothing:
//   - it stops when it writes RESET ← 1, HOLD ← 1 or SVON ← 0;
//   - otherwise, when each coil it writes that matters releases (RESET,
//     DRIVE, SETUP, JOG−, JOG+ ← 0) and none starts (SVON, DRIVE, SETUP,
//     JOG−, JOG+ ← 1, or HOLD ← 0, which resumes a held operation).
// IN0–IN5 and Y30 neither stop nor start. An FC10 write of the control words
// D90C1 (Y10–Y1F as one word, bit 0 = Y10) and D90C2 (Y30–Y3F) is the same
// coil levels written at once, judged alike (a PLC's HOLD as a word is a
// stop). Reads, other register writes (a D9100 start) and coil values other
// than FF00/0000 (refused: exception 03) are not stops. The table test is
// tests/client/stop_rule_test.cpp (every coil at both levels, every value of
// both control words).
bool stops_or_releases(const modbus::Request& request) noexcept;

// A write that stops by itself: RESET ← 1, HOLD ← 1 or SVON ← 0 among the
// coil levels it writes (FC05, FC0F, FC10 to the control words, as above).
// A release alone (RESET, DRIVE, JOG ← 0) is not: it ends a pulse.
bool stops_hard(const modbus::Request& request) noexcept;

// A write that may start or resume motion: SVON, DRIVE, SETUP, JOG−, JOG+ ← 1
// or HOLD ← 0 among its coil levels, or a write of D9100 (a direct start).
// lec serve refuses such a write still queued when a hard stop to its
// controller arrives (scheduler.cpp: a stop supersedes it).
bool starts_motion(const modbus::Request& request) noexcept;

}  // namespace lec6::client
