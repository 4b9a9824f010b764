#pragma once
// What a UART set to a rate other than the line's makes of what it hears,
// sans-I/O: `lec sim`'s strict baud (twin/sim_server.cpp) and the in-process
// line (twin/virtual_line.hpp) play it both ways, on the controllers' side
// (a query sent at the wrong rate) and on the master's (what it hears).
//
// Not a model of the bits, only of what the other end sees: fewer bytes
// than were sent (every other one), none of them the same (each XOR 0x5A),
// so a frame's CRC no longer holds (but by a 1-in-65536 chance).
//
// Thread safety: a pure function.

#include <span>

#include "lec6/modbus/pdu.hpp"

namespace lec6::sim {

modbus::Bytes garble_wrong_baud(std::span<const uint8_t> bytes);

}  // namespace lec6::sim
