#pragma once
// The twin's EEPROM on disk (digest §6 "Memory"): step data, alarm history,
// equipment name and per-step write counters of every controller on the bus.
// Flags, direct-operation data and the state area are RAM and are not kept.
//
// Format: UTF-8 text, one record a line, so a person can read and diff it:
//
//   lec6-twin-state 1
//   controller 1
//   name LEC6-TWIN
//   step 1 writes 2 0001 01F4 0000 3A98 1388 1388 0000 0000 0014 0064 0000 0000 0000 0000 0000 0064
//   alarm 0 34 00 00 00 00 00 00 00
//   end
//
// Steps that are blank and never written, and empty alarm groups, are left out.
// This is the text, sans-I/O; the file is read and written by
// twin/state_file_io.hpp (atomically: a crash leaves the old or the new file).
//
// Thread safety: the functions share nothing; two saves of the same path at once race (the last
// rename wins, neither file is torn).

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <string_view>

#include "lec6/expected.hpp"
#include "lec6/sim/controller.hpp"

namespace lec6::sim {

using EepromSet = std::map<uint8_t, Eeprom>;  // by controller ID

std::string serialize_state(const EepromSet& state);
Expected<EepromSet, std::string> parse_state(std::string_view text);

}  // namespace lec6::sim
